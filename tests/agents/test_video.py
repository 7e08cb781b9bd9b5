"""Episode videos (spine_gym.agents.video, ``spine_gym.agents.evaluate --video``): the MP4 decodes to one frame per
reset and step, and its frames are the env's rgb_array frames."""

from __future__ import annotations

import imageio_ffmpeg
import numpy as np
import pytest

from spine_gym.agents import evaluate as ev
from spine_gym.agents import video


def decode(path):
    """(metadata, frames (n, H, W, 3) uint8) of a video file, decoded by ffmpeg."""
    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    frames = np.array([np.frombuffer(f, dtype=np.uint8).reshape(h, w, 3) for f in gen])
    return meta, frames


class HeatRight:
    """Right wire at full voltage (SB3's ``predict``): the spine bends, so the frames change."""

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.array([[1.0, -1.0]], dtype=np.float32), state


def test_record_episode_writes_one_decodable_frame_per_reset_and_step(tmp_path):
    env = ev.make_env({"episode_duration": 2.0, "render_mode": "rgb_array"})
    path = tmp_path / "heat.mp4"
    n, traj = video.record_episode(path, env, lambda e: ev.run_episode(e, HeatRight(), seed=3))
    assert n == 21 and len(traj.time) == 20  # 2 s / 0.1 s steps + the reset frame
    meta, frames = decode(path)
    assert frames.shape == (21, 480, 480, 3) and meta["fps"] == pytest.approx(10.0)
    last = env.render().astype(float)  # the env is left at the episode's last state
    err_last = np.abs(frames[-1] - last).mean()
    assert err_last < 1.0  # lossy H.264 of the same picture (0.4 of 255 measured)
    assert err_last < 0.5 * np.abs(frames[0] - last).mean()  # ... and not some other frame
    env.close()


def test_record_episode_rejects_bad_input(tmp_path):
    env = ev.make_env({"episode_duration": 1.0})
    with pytest.raises(ValueError, match="render_mode"):
        video.record_episode(tmp_path / "x.mp4", env, lambda e: None)
    env = ev.make_env({"episode_duration": 1.0, "render_mode": "rgb_array"})
    with pytest.raises(ValueError, match=r"speed must be a number in \[0.01, 100\], got 0"):
        video.record_episode(tmp_path / "x.mp4", env, lambda e: None, speed=0)


def test_evaluate_cli_writes_a_video_per_controller_and_scenario(tmp_path):
    ev.main(
        ["--suite", "quick", "--scenarios", "step_cross", "--baselines", "step", "--models",
         "--video", "--video-speed", "2", "--no-plots", "--no-trajectories", "--plain", "-o", str(tmp_path)]
    )  # fmt: skip
    path = tmp_path / "videos" / "step" / "step_cross.mp4"
    meta, frames = decode(path)
    assert len(frames) == 201 and meta["fps"] == pytest.approx(20.0)  # 20-s scenario at 2x speed
    assert sorted(p.name for p in (tmp_path / "videos").rglob("*.mp4")) == ["step_cross.mp4"]
