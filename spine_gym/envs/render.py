"""``render_mode="rgb_array"`` frames of the spine (matplotlib, imported only when drawing).

The centre line comes from :func:`spine_gym.physics.tube.vertices` (the model's own geometry);
the two wires are drawn at the offset ``a`` on either side and coloured by their temperature; the
target is drawn as a dashed circular arc of the spine's length that turns by the target angle; an
active tip force (plus payload weight) is an arrow on the top disk, 0.3 spine lengths per newton.
"""

from __future__ import annotations

import math

import numpy as np

from ..physics import layout as L
from ..physics.tube import vertices

FRAME_SIZE = (480, 480)  # [px] width, height


class SpineRenderer:
    """Keeps one matplotlib figure (Agg canvas, no pyplot state) and draws frames into it."""

    def __init__(self, temperature_limit: float, size: tuple[int, int] = FRAME_SIZE):
        self.temperature_limit = float(temperature_limit)
        self.size = size
        self._fig = None

    def _setup(self):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        dpi = 100
        self._fig = Figure(figsize=(self.size[0] / dpi, self.size[1] / dpi), dpi=dpi)
        FigureCanvasAgg(self._fig)
        self._ax = self._fig.add_axes((0.0, 0.0, 1.0, 1.0))

    def draw(self, s: dict) -> np.ndarray:
        """Frame (H, W, 3) uint8 of a :meth:`SpineBatch.state_summary` dict."""
        import matplotlib

        if self._fig is None:
            self._setup()
        ax = self._ax
        ax.clear()
        kp = s["kp"]
        length = kp[L.K_LS] * s["dth"].shape[0]
        a = kp[L.K_A]
        p = vertices(s["dth"], kp)[::-1]  # base P_N first
        # unit normals pointing to the right wire (+x when straight)
        seg = np.diff(p, axis=0)
        tang = np.vstack([seg[:1], 0.5 * (seg[:-1] + seg[1:]), seg[-1:]])
        tang /= np.linalg.norm(tang, axis=1, keepdims=True)
        normal = np.column_stack([tang[:, 1], -tang[:, 0]])
        cmap = matplotlib.colormaps["coolwarm"]
        t_lo, t_hi = s["ambient"], max(self.temperature_limit, s["ambient"] + 1.0)
        half = 0.62 * length
        ax.set_xlim(-half, half)
        ax.set_ylim(-0.12 * length, 1.12 * length)
        ax.set_aspect("equal")
        ax.axis("off")
        ax.axhline(0.0, color="0.3", lw=3)
        # target: constant-curvature arc of the spine's length turning by the target angle
        th = math.radians(s["target_deg"])
        u = np.linspace(0.0, 1.0, 50)
        if abs(th) < 1e-6:
            arc = np.column_stack([0.0 * u, length * u])
        else:
            r = length / th
            arc = np.column_stack([r * (1.0 - np.cos(th * u)), r * np.sin(th * u)])
        ax.plot(arc[:, 0], arc[:, 1], ls="--", color="tab:green", lw=2, label="target")
        # tube and rings
        ax.plot(p[:, 0], p[:, 1], color="0.55", lw=10, solid_capstyle="round", zorder=1)
        for q, nrm in zip(p, normal, strict=True):
            ax.plot(
                [q[0] - 1.3 * a * nrm[0], q[0] + 1.3 * a * nrm[0]],
                [q[1] - 1.3 * a * nrm[1], q[1] + 1.3 * a * nrm[1]],
                color="0.25",
                lw=2,
                zorder=2,
            )
        # wires coloured by temperature (right wire at +normal)
        for sign, temp in ((1.0, s["temperature"][0]), (-1.0, s["temperature"][1])):
            w = p + sign * a * normal
            c = cmap(np.clip((temp - t_lo) / (t_hi - t_lo), 0.0, 1.0))
            ax.plot(w[:, 0], w[:, 1], color=c, lw=3, zorder=3)
        # tip force
        f = np.asarray(s["tip_force"], dtype=float)
        fn = float(np.hypot(*f))
        if fn > 1e-9:
            tip = p[-1]
            d = f / fn * length * min(max(0.3 * fn, 0.05), 0.4)  # 0.3 L per newton, clipped
            ax.annotate("", xy=tip + d, xytext=tip, arrowprops={"arrowstyle": "-|>", "color": "k", "lw": 2})
        txt = (
            f"t = {s['time']:6.1f} s\nangle {s['angle_deg']:+6.1f} deg  target {s['target_deg']:+6.1f} deg\n"
            f"T right {s['temperature'][0]:5.0f} K  left {s['temperature'][1]:5.0f} K\n"
            f"V right {s['voltage'][0]:4.2f} V  left {s['voltage'][1]:4.2f} V"
        )
        ax.text(0.02, 0.98, txt, transform=ax.transAxes, va="top", ha="left", family="monospace", fontsize=8)
        canvas = self._fig.canvas
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()

    def close(self):
        self._fig = None
