"""The ``rgb_array`` frames (spine_gym.envs.render) and the evaluation plots (spine_gym.plotting):
every panel of a frame shows something, rendering leaves the rollout untouched, and the evaluation
plots shade the disturbance windows and label the temperature limit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from matplotlib.colors import to_rgb

from spine_gym.agents import evaluate as ev
from spine_gym.agents.metrics import Trajectory
from spine_gym.agents.scenarios import get_suite
from spine_gym.envs.render import FRAME_SIZE, wire_color
from spine_gym.envs.loads import LoadSchedule, TipForceEvent
from spine_gym.plotting import PAYLOAD_LABEL, PUSH_LABEL, disturbance_windows, episode_figure, plot_episodes

IDS = ["SmaSpine-v1", "SmaSpine3D-v1", "SmaSpineChain-v1"]
SHORT = {"episode_duration": 2.0}  # [s] 20 steps
MIN_INK = 0.02  # [-] least share of non-background pixels in a panel


def pushed_loads(env_id: str) -> LoadSchedule:
    """A 0.3-N push from 0.5 s to 1.5 s and a 20-g payload."""
    force = (0.3, 0.0) if env_id == "SmaSpine-v1" else (0.2, 0.2, 0.0)
    return LoadSchedule((TipForceEvent(0.5, 1.5, force),), payload=0.02, dim=len(force))


def heat_first(env) -> np.ndarray:
    """Wire 0 at full voltage, the others off."""
    a = -np.ones(env.action_space.shape, dtype=np.float32)
    a[0] = 1.0
    return a


def rollout(env_id: str, render: bool, steps: int = 12) -> list:
    """Seeded rollout with a push; observations, rewards and infos, then a reset drawn from the
    env's own random stream (no seed) to compare the streams."""
    env = gym.make(env_id, render_mode="rgb_array" if render else None, **SHORT)
    obs, _ = env.reset(seed=5, options={"loads": pushed_loads(env_id)})
    out = [obs]
    for _ in range(steps):
        obs, reward, _, _, info = env.step(heat_first(env))
        out += [obs, reward, info["temperature"]]
        if render:
            env.render()
    out.append(env.reset()[0])
    env.close()
    return out


@pytest.mark.parametrize("env_id", IDS)
def test_every_panel_of_a_frame_has_content(env_id):
    env = gym.make(env_id, render_mode="rgb_array", **SHORT)
    env.reset(seed=1, options={"loads": pushed_loads(env_id)})
    for _ in range(8):
        env.step(heat_first(env))
        frame = env.render()
    assert frame.shape == (FRAME_SIZE[1], FRAME_SIZE[0], 3) and frame.dtype == np.uint8
    boxes = env.unwrapped._renderer.panel_boxes()
    assert len(boxes) >= 2
    for name, (r0, r1, c0, c1) in boxes.items():
        panel = frame[r0:r1, c0:c1]
        ink = (panel < 235).any(axis=2).mean()
        assert ink > MIN_INK, f"{env_id} panel {name!r} is nearly empty ({ink:.1%} ink)"
    env.close()


@pytest.mark.parametrize("env_id", IDS[1:])
def test_spatial_frame_shows_the_heated_wire_and_the_tip_path(env_id):
    env = gym.make(env_id, render_mode="rgb_array", **SHORT)
    env.reset(seed=1)
    for _ in range(15):
        env.step(heat_first(env))
        frame = env.render()
    renderer = env.unwrapped._renderer
    kw = env.unwrapped._core.state_summary(0)["kw"]
    dark = np.array(to_rgb(wire_color(0, kw, 1.0))) * 255.0  # wire 0 near the temperature limit
    near = np.abs(frame.astype(float) - dark).max(axis=2) < 60.0
    assert near.sum() > 20
    assert len(renderer._paths[0]) == 15  # one point per rendered step
    env.render()
    assert len(renderer._paths[0]) == 15  # the same state drawn again adds no point
    env.reset(seed=2)
    env.render()
    assert len(renderer._paths[0]) == 1  # a new episode starts a new path
    env.close()


def test_vector_env_frames_keep_one_tip_path_per_env():
    venv = gym.make_vec("SmaSpine3D-v1", num_envs=2, render_mode="rgb_array", **SHORT)
    venv.reset(seed=[1, 2])
    for _ in range(3):
        venv.step(np.zeros((2, 4), dtype=np.float32))
        frames = venv.render()
    assert len(frames) == 2 and all(f.shape == (480, 480, 3) for f in frames)
    paths = venv.unwrapped._renderer._paths
    assert set(paths) == {0, 1} and {len(p) for p in paths.values()} == {3}
    venv.close()


@pytest.mark.parametrize("env_id", IDS)
def test_rendering_does_not_change_the_rollout(env_id):
    plain, rendered = rollout(env_id, render=False), rollout(env_id, render=True)
    for a, b in zip(plain, rendered, strict=True):
        assert np.array_equal(a, b)


def fake_trajectory(duration: float, n_wires: int, dim: int) -> Trajectory:
    """A trajectory of ``duration`` seconds at 0.1 s with made-up numbers (no simulation)."""
    t = np.arange(1, round(duration / 0.1) + 1) * 0.1
    n = t.size
    wave = np.sin(t)[:, None] * np.ones((1, dim))
    return Trajectory(
        time=t,
        angle_deg=wave.squeeze(1) if dim == 1 else wave,
        target_deg=0.0 * wave.squeeze(1) if dim == 1 else 0.0 * wave,
        voltage=np.ones((n, n_wires)),
        temperature=300.0 + 10.0 * np.abs(wave[:, :1]) * np.ones((1, n_wires)),
        energy_J=np.zeros(n),
        cost=np.zeros(n),
        action=np.zeros((n, n_wires)),
    )


def test_disturbance_windows_come_from_the_load_schedule():
    loads = LoadSchedule((TipForceEvent(2.0, 4.0, (0.3, 0.4)), TipForceEvent(8.0, np.inf, (0.0, 1.0))), 0.05)
    assert disturbance_windows(loads, 10.0) == [
        (2.0, 4.0, "push", "0.5 N"),
        (8.0, 10.0, "push", "1 N"),
        (0.0, 10.0, "payload", "50 g"),
    ]
    assert disturbance_windows(None, 10.0) == [] == disturbance_windows(LoadSchedule(), 10.0)


@pytest.mark.parametrize(("env_id", "n_wires", "dim"), [("SmaSpine-v0", 2, 1), ("SmaSpine3D-v0", 4, 2)])
def test_evaluation_plot_shades_pushes_and_payload_and_labels_the_limit(tmp_path, env_id, n_wires, dim):
    disturbed = [sc for sc in get_suite("quick", env_id=env_id) if sc.group == "disturbed"][:2]
    nominal = [sc for sc in get_suite("quick", env_id=env_id) if sc.group == "nominal"][0]
    episodes = [
        (sc.name, fake_trajectory(sc.duration, n_wires, dim), sc.reset_options()["loads"])
        for sc in [nominal, *disturbed]
    ]
    fig = episode_figure(episodes, 350.0)
    axes = np.array(fig.axes).reshape(3, len(episodes))
    for j, (_, traj, loads) in enumerate(episodes):
        n_push = len([w for w in disturbance_windows(loads, traj.time[-1]) if w[2] == "push"])
        for ax in axes[:, j]:
            labels = [p.get_label() for p in ax.patches]
            assert labels.count(PUSH_LABEL) == n_push
            assert labels.count(PAYLOAD_LABEL) == (loads.payload > 0.0)
        assert n_push == (0 if j == 0 else len(disturbed[j - 1].tip_pulses)) and (j == 0 or n_push > 0)
        limit = [ln for ln in axes[2, j].lines if ln.get_label() == "temperature limit 350 K"]
        assert len(limit) == 1 and limit[0].get_ydata()[0] == 350.0
    legend = {t.get_text() for t in fig.legends[0].get_texts()}
    assert {PUSH_LABEL, PAYLOAD_LABEL, "temperature limit 350 K"} <= legend
    path = plot_episodes(episodes, tmp_path / "e.png", temperature_limit=350.0)
    assert path.stat().st_size > 10_000


def test_evaluate_writes_the_group_plot_from_the_scenarios(tmp_path):
    scenarios = [sc for sc in get_suite("quick") if sc.group == "disturbed"][:2]
    trajs = {("ctrl", sc.name): fake_trajectory(sc.duration, 2, 1) for sc in scenarios}
    path = tmp_path / "plots" / "ctrl_disturbed.png"
    ev.plot_controller(path, "ctrl", "disturbed", scenarios, trajs, 353.0)
    assert path.stat().st_size > 10_000
