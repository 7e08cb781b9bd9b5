"""Write the example ``rgb_array`` frames of docs/images/: each env id runs a disturbed scenario
of its ``quick`` suite under the PID baseline, rendering every step (the top view's tip path needs
the history), and the frame at ``SNAPSHOT_S`` (a tip push acting) is saved as a PNG.

Usage: ``python scripts/render_doc_frames.py [OUT_DIR]`` (default ``docs/images``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np

from spine_gym.agents.runtime import build_controller, make_env
from spine_gym.agents.scenarios import get_suite

SNAPSHOT_S = 9.0  # [s] time of the saved frame: inside a push of each scenario below
SCENARIOS = {  # env id -> disturbed scenario of its quick suite
    "SmaSpine-v1": "step_cross_dist",
    "SmaSpine3D-v1": "circle_dist",
    "SmaSpineChain-v1": "steps_dist",
}


def snapshot(env_id: str, scenario: str) -> np.ndarray:
    """The frame at ``SNAPSHOT_S`` of ``scenario`` under PID."""
    (sc,) = get_suite("quick", names=[scenario], env_id=env_id)
    env = make_env({"episode_duration": sc.duration, "render_mode": "rgb_array"}, env_id=env_id)
    ctrl = build_controller("pid", env)
    if hasattr(ctrl, "reset"):
        ctrl.reset()
    obs, _ = env.reset(seed=sc.seed, options=sc.reset_options())
    start = np.ones((1,), dtype=bool)
    state = None
    for _ in range(round(SNAPSHOT_S / env.control_period)):
        action, state = ctrl.predict(obs[None, :], state=state, episode_start=start, deterministic=True)
        start = np.zeros((1,), dtype=bool)
        obs, *_ = env.step(np.asarray(action, dtype=np.float32).reshape(env.action_space.shape))
        frame = env.render()
    env.close()
    return frame


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for env_id, scenario in SCENARIOS.items():
        path = out / f"frame_{env_id}.png"
        mpimg.imsave(path, snapshot(env_id, scenario))
        print(f"wrote {path}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("docs/images"))
