"""MP4 videos of evaluation episodes from the env's ``rgb_array`` frames (imageio-ffmpeg).

``python -m spine_gym.agents.evaluate --video`` writes ``videos/<controller>/<scenario>.mp4`` under its
output folder: each controller runs each scenario once more in an env made with
``render_mode="rgb_array"`` (same seed, target, loads and deterministic policy as the evaluated
episode), and every frame — the one after ``reset`` and one after each step, so
``duration / control_period + 1`` frames — goes straight into an H.264 stream (nothing is kept in
memory). A frame shows the spine, the target as a dashed arc, the wires coloured by temperature
and the time, angle, target, wire temperatures and voltages as text
(:class:`spine_gym.envs.render.SpineRenderer`).

Filming costs ~45 ms per frame (rendering with matplotlib, encoding, the episode itself; measured
on the shared 2-core machine, an upper bound): ``--suite quick`` (6 scenarios of 20 s) took 5.3 min
for the 6 controllers, a 60-s episode takes ~27 s, the full suite ~6 min per controller;
``--groups``/``--scenarios``/``--baselines``/``--models`` select what to film. Needs the ``video``
extra (``pip install "spine_gym[video]"``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm.auto import tqdm

from .scenarios import Scenario

try:  # an optional extra: evaluate.py works without it, only --video needs it
    import imageio_ffmpeg
except ImportError:  # pragma: no cover - the [video] extra is installed by scripts/setup.sh
    imageio_ffmpeg = None

__all__ = ["FrameRecorder", "record_episode", "require_ffmpeg", "write_videos", "video_path"]

CODEC = "libx264"
PIX_FMT = "yuv420p"  # plays in browsers and the notebook's Video widget
QUALITY = 7  # imageio-ffmpeg's 0-10 scale (10 = best); 0.24-0.42 MB per 20-s episode at 480 x 480


class FrameRecorder(gym.Wrapper):
    """Hands ``env.render()`` to ``sink`` after ``reset`` and after every ``step``."""

    def __init__(self, env: gym.Env, sink: Callable[[np.ndarray], None]):
        super().__init__(env)
        self.sink = sink
        self.n_frames = 0

    def _frame(self) -> None:
        self.sink(np.ascontiguousarray(self.env.render()))
        self.n_frames += 1

    def reset(self, **kwargs):
        out = self.env.reset(**kwargs)
        self._frame()
        return out

    def step(self, action):
        out = self.env.step(action)
        self._frame()
        return out


def require_ffmpeg() -> None:
    """RuntimeError unless imageio-ffmpeg (the ``video`` extra) is installed."""
    if imageio_ffmpeg is None:
        raise RuntimeError('videos need the video extra: pip install "spine_gym[video]" (imageio-ffmpeg)')


def record_episode(path: Path, env: gym.Env, run: Callable[[gym.Env], object], *, speed: float = 1.0):
    """Call ``run(recorder)`` on ``env`` (made with ``render_mode="rgb_array"``) wrapped in a
    :class:`FrameRecorder` that streams every frame into the MP4 ``path``.

    Args:
        path: output file (folders are created).
        env: the env to film.
        run: plays the episode on the env it gets (e.g. ``spine_gym.agents.runtime.run_episode`` with a
            policy and a scenario bound).
        speed: playback speed (1 = real time: ``env.metadata["render_fps"]`` frames per second).

    Returns:
        ``(number of frames written, what run returned)``.
    """
    require_ffmpeg()
    if isinstance(speed, bool) or not isinstance(speed, int | float) or not 0.01 <= speed <= 100.0:
        raise ValueError(f"speed must be a number in [0.01, 100], got {speed!r}")
    if env.render_mode != "rgb_array":
        raise ValueError(f"env.render_mode must be 'rgb_array' to film it, got {env.render_mode!r}")
    fps = speed * float(env.metadata["render_fps"])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    writer = None

    def sink(frame: np.ndarray) -> None:
        nonlocal writer
        if writer is None:  # the frame size is known with the first frame
            h, w = frame.shape[:2]
            writer = imageio_ffmpeg.write_frames(
                str(path), (w, h), fps=fps, codec=CODEC, pix_fmt_out=PIX_FMT, quality=QUALITY
            )
            writer.send(None)  # start the generator
        writer.send(frame)

    recorder = FrameRecorder(env, sink)
    try:
        result = run(recorder)
    finally:
        if writer is not None:
            writer.close()
    return recorder.n_frames, result


def video_path(out: Path, controller: str, scenario: Scenario) -> Path:
    """Where :func:`write_videos` puts the video of one (controller, scenario)."""
    return Path(out) / controller / f"{scenario.name}.mp4"


def write_videos(
    controllers: dict[str, object],
    scenarios: Iterable[Scenario],
    out: Path,
    env_kwargs: dict[str, dict] | None = None,
    *,
    make_env: Callable[[dict], gym.Env],
    run_episode: Callable[[gym.Env, object, Scenario], object],
    speed: float = 1.0,
    progress: bool = True,
) -> list[Path]:
    """One MP4 per (controller, scenario) under ``out`` (see :func:`video_path`); returns the paths.

    ``make_env(kwargs)`` and ``run_episode(env, policy, scenario)`` are those of
    :mod:`spine_gym.agents.evaluate` (passed in: that module calls this one), so the filmed episode is the
    evaluated one; the env gets the controller's ``env_kwargs``, the scenario's duration and
    ``render_mode="rgb_array"``.
    """
    require_ffmpeg()
    scenarios = list(scenarios)
    jobs = [(name, sc) for name in controllers for sc in scenarios]
    paths = []
    for name, sc in tqdm(jobs, desc="videos", unit="video", disable=not progress):
        kw = {**(env_kwargs or {}).get(name, {}), "episode_duration": sc.duration, "render_mode": "rgb_array"}
        env = make_env(kw)
        try:
            path = video_path(out, name, sc)
            record_episode(path, env, lambda e, n=name, s=sc: run_episode(e, controllers[n], s), speed=speed)
        finally:
            env.close()
        paths.append(path)
    return paths
