"""``render_mode="rgb_array"`` frames of the spine (matplotlib; this module is imported on the
first ``render()`` so that ``import spine_gym`` stays free of matplotlib).

The centre line comes from :func:`spine_gym.physics.tube.vertices` (the model's own geometry);
the two wires are drawn at the offset ``a`` on either side and coloured by their temperature on a
scale from the ambient temperature to ``temperature_limit`` (the colour bar on the right, with a
mark at each wire's temperature); the target is drawn as a dashed circular arc of the spine's
length that turns by the target angle; an active tip force (plus payload weight) is an arrow on the
top disk, 0.3 spine lengths per newton. Time, angle, target, wire temperatures and voltages are
printed in the top-left corner. The artists are made once; per frame only the moving ones are
drawn over a saved background (redrawn when the temperature scale or the spine length changes).
"""

from __future__ import annotations

import math

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from ..physics import layout as L
from ..physics import spatial_layout as SL
from ..physics.spatial_tube import kinematics, positions
from ..physics.tube import vertices
from .task_spatial import arc_positions

FRAME_SIZE = (480, 480)  # [px] width, height
CMAP = "coolwarm"  # wire colour: blue at ambient, red at the temperature limit
TARGET_COLOR = "tab:green"


class SpineRenderer:
    """Keeps one matplotlib figure (Agg canvas, no pyplot state) and draws frames into it."""

    def __init__(self, temperature_limit: float, size: tuple[int, int] = FRAME_SIZE):
        self.temperature_limit = float(temperature_limit)
        self.size = size
        self._fig = None

    def _setup(self):
        dpi = 100
        self._fig = fig = Figure(figsize=(self.size[0] / dpi, self.size[1] / dpi), dpi=dpi)
        FigureCanvasAgg(fig)
        self._ax = ax = fig.add_axes((0.0, 0.0, 0.86, 1.0))
        ax.set_aspect("equal")
        ax.axis("off")
        ax.axhline(0.0, color="0.3", lw=3)
        self._cmap = matplotlib.colormaps[CMAP]
        (self._target,) = ax.plot([], [], ls="--", color=TARGET_COLOR, lw=2, label="target")
        (self._tube,) = ax.plot([], [], color="0.55", lw=10, solid_capstyle="round", zorder=1)
        self._rings = LineCollection([], colors="0.25", linewidths=2, zorder=2)
        ax.add_collection(self._rings)
        self._wires = [ax.plot([], [], lw=3, zorder=3)[0] for _ in range(2)]
        self._arrow = ax.annotate(
            "", xy=(0.0, 0.0), xytext=(0.0, 0.0), arrowprops={"arrowstyle": "-|>", "color": "k", "lw": 2}
        )
        self._text = ax.text(
            0.02, 0.98, "", transform=ax.transAxes, va="top", ha="left", family="monospace", fontsize=8
        )
        ax.legend(loc="lower left", fontsize=7, frameon=False)
        # temperature scale of the wire colours, with a mark per wire
        cax = fig.add_axes((0.83, 0.25, 0.035, 0.6))
        self._scale = ScalarMappable(Normalize(0.0, 1.0), self._cmap)
        bar = fig.colorbar(self._scale, cax=cax)
        bar.ax.tick_params(labelsize=7)
        bar.set_label("wire temperature [K]", fontsize=7)
        self._marks = [
            cax.plot([0.0, 1.0], [0.0, 0.0], color="k", lw=1.5, transform=cax.get_yaxis_transform())[0]
            for _ in range(2)
        ]
        self._mark_labels = [
            cax.text(
                -0.15, 0.0, side, ha="right", va="center", fontsize=7, transform=cax.get_yaxis_transform()
            )
            for side in ("R", "L")
        ]
        # what changes per frame is drawn over a saved background (blitting)
        self._dynamic = sorted(
            [self._target, self._tube, self._rings, *self._wires, self._arrow, self._text]
            + [*self._marks, *self._mark_labels],
            key=lambda a: a.get_zorder(),
        )
        for a in self._dynamic:
            a.set_animated(True)  # left out of the full draw that makes the background
        self._background = None
        self._background_key = None

    def _update_background(self, key: tuple[float, float, float]) -> None:
        """Redraw the static parts (axes limits, colour scale, legend, base) if ``key`` changed."""
        if key == self._background_key:
            return
        t_lo, t_hi, length = key
        half = 0.62 * length
        self._ax.set_xlim(-half, half)
        self._ax.set_ylim(-0.12 * length, 1.12 * length)
        self._scale.set_clim(t_lo, t_hi)
        canvas = self._fig.canvas
        canvas.draw()
        self._background = canvas.copy_from_bbox(self._fig.bbox)
        self._background_key = key

    def draw(self, s: dict) -> np.ndarray:
        """Frame (H, W, 3) uint8 of a :meth:`SpineBatch.state_summary` dict."""
        if self._fig is None:
            self._setup()
        kp = s["kp"]
        length = kp[L.K_LS] * s["dth"].shape[0]
        a = kp[L.K_A]
        p = vertices(s["dth"], kp)[::-1]  # base P_N first
        # unit normals pointing to the right wire (+x when straight)
        seg = np.diff(p, axis=0)
        tang = np.vstack([seg[:1], 0.5 * (seg[:-1] + seg[1:]), seg[-1:]])
        tang /= np.linalg.norm(tang, axis=1, keepdims=True)
        normal = np.column_stack([tang[:, 1], -tang[:, 0]])
        t_lo, t_hi = s["ambient"], max(self.temperature_limit, s["ambient"] + 1.0)
        self._update_background((float(t_lo), float(t_hi), float(length)))
        # target: constant-curvature arc of the spine's length turning by the target angle
        th = math.radians(s["target_deg"])
        u = np.linspace(0.0, 1.0, 50)
        if abs(th) < 1e-6:
            arc = np.column_stack([0.0 * u, length * u])
        else:
            r = length / th
            arc = np.column_stack([r * (1.0 - np.cos(th * u)), r * np.sin(th * u)])
        self._target.set_data(arc[:, 0], arc[:, 1])
        # tube and rings
        self._tube.set_data(p[:, 0], p[:, 1])
        self._rings.set_segments(
            [[q - 1.3 * a * nrm, q + 1.3 * a * nrm] for q, nrm in zip(p, normal, strict=True)]
        )
        # wires coloured by temperature (right wire at +normal)
        for k, (sign, temp) in enumerate(((1.0, s["temperature"][0]), (-1.0, s["temperature"][1]))):
            w = p + sign * a * normal
            self._wires[k].set_data(w[:, 0], w[:, 1])
            self._wires[k].set_color(self._cmap(np.clip((temp - t_lo) / (t_hi - t_lo), 0.0, 1.0)))
            level = min(max(temp, t_lo), t_hi)  # marks of temperatures off the scale sit at its ends
            self._marks[k].set_ydata([level, level])
            self._mark_labels[k].set_y(level)
        # tip force
        f = np.asarray(s["tip_force"], dtype=float)
        fn = float(np.hypot(*f))
        self._arrow.set_visible(fn > 1e-9)
        if fn > 1e-9:
            tip = p[-1]
            d = f / fn * length * min(max(0.3 * fn, 0.05), 0.4)  # 0.3 L per newton, clipped
            self._arrow.xy = tuple(tip + d)
            self._arrow.set_position(tuple(tip))
        self._text.set_text(
            f"t = {s['time']:6.1f} s\nangle {s['angle_deg']:+6.1f} deg  target {s['target_deg']:+6.1f} deg\n"
            f"T right {s['temperature'][0]:5.0f} K  left {s['temperature'][1]:5.0f} K\n"
            f"V right {s['voltage'][0]:4.2f} V  left {s['voltage'][1]:4.2f} V"
        )
        canvas = self._fig.canvas
        canvas.restore_region(self._background)
        for a in self._dynamic:
            self._fig.draw_artist(a)
        return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()

    def close(self):
        self._fig = None


def make_renderer(cfg):
    """The renderer of an env configuration: :class:`SpineRenderer` (planar) or
    :class:`SpatialRenderer` (``SmaSpine3D-v0``, ``SmaSpineChain-v0``)."""
    if hasattr(cfg, "layout"):
        return SpatialRenderer(cfg.temperature_limit)
    return SpineRenderer(cfg.temperature_limit)


class SpatialRenderer:
    """Frames of a spatial spine: two orthogonal views (x-z left, y-z right) of the centre line
    (the spatial core's kinematics), each wire group at its pore offset coloured by temperature
    (blue = ambient, red = ``temperature_limit``), the target (a dashed arc for a bending target,
    a cross for a tip-position target), the force on the top disk as an arrow (0.3 spine lengths
    per newton)."""

    def __init__(self, temperature_limit: float, size: tuple[int, int] = FRAME_SIZE):
        self.temperature_limit = float(temperature_limit)
        self.size = size
        self._fig = None

    def _setup(self):
        dpi = 100
        self._fig = fig = Figure(figsize=(self.size[0] / dpi, self.size[1] / dpi), dpi=dpi)
        FigureCanvasAgg(fig)
        self._axes = [fig.add_axes((0.01 + 0.42 * c, 0.0, 0.41, 0.86)) for c in range(2)]
        self._cmap = matplotlib.colormaps[CMAP]
        self._text = fig.text(0.02, 0.985, "", va="top", ha="left", family="monospace", fontsize=7)
        cax = fig.add_axes((0.85, 0.25, 0.03, 0.5))
        self._scale = ScalarMappable(Normalize(0.0, 1.0), self._cmap)
        bar = fig.colorbar(self._scale, cax=cax)
        bar.ax.tick_params(labelsize=6)
        bar.set_label("wire temperature [K]", fontsize=7)

    def draw(self, s: dict) -> np.ndarray:
        """Frame (H, W, 3) uint8 of a :meth:`SpatialBatch.state_summary` dict."""
        if self._fig is None:
            self._setup()
        km, kw = s["km"], s["kw"]
        ns = s["omega"].shape[0]
        frames = np.empty((ns + 1, 3, 3))
        chords = np.empty((ns, 3))
        pos = np.empty((ns + 1, 3))
        kinematics(s["omega"], km, frames, chords)
        positions(chords, pos)
        length = s["length"]
        t_lo, t_hi = s["ambient"], max(self.temperature_limit, s["ambient"] + 1.0)
        self._scale.set_clim(t_lo, t_hi)
        target = np.asarray(s["target"])
        if s["task"] == "tip_bending_deg":
            arc = arc_positions(target[None, :], km[:1] if km.shape[0] == 1 else km) / 1000.0
            target_pts = arc if km.shape[0] == 1 else None
        else:
            target_pts = target[None, :] / 1000.0
        f = np.asarray(s["tip_force"], dtype=float)
        for c, ax in enumerate(self._axes):
            ax.cla()
            ax.set_aspect("equal")
            ax.axis("off")
            half = 0.75 * length
            ax.set_xlim(-half, half)
            ax.set_ylim(-0.1 * length, 1.12 * length)
            ax.axhline(0.0, color="0.3", lw=3)
            ax.set_title("x-z (front)" if c == 0 else "y-z (side)", fontsize=8)
            ax.plot(pos[:, c], pos[:, 2], color="0.55", lw=8, solid_capstyle="round", zorder=1)
            for j in range(kw.shape[0]):
                k = int(kw[j, SL.W_MOD])
                s0, nk = int(km[k, SL.M_SEG0]), int(km[k, SL.M_NSEG])
                ex, ey, a = kw[j, SL.W_EX], kw[j, SL.W_EY], kw[j, SL.W_A]
                fr = frames[s0 : s0 + nk + 1]
                w = pos[s0 : s0 + nk + 1] + a * (ey * fr[:, 0] - ex * fr[:, 1])  # pore at (cos ψ, sin ψ)
                level = np.clip((s["temperature"][j] - t_lo) / (t_hi - t_lo), 0.0, 1.0)
                ax.plot(w[:, c], w[:, 2], lw=2.5, color=self._cmap(level), zorder=3)
            if target_pts is not None:
                style = (
                    {"ls": "--", "lw": 2} if target_pts.shape[0] > 1 else {"marker": "x", "ms": 10, "mew": 3}
                )
                ax.plot(target_pts[:, c], target_pts[:, 2], color=TARGET_COLOR, zorder=4, **style)
            fn = float(np.linalg.norm(f))
            if fn > 1e-9:
                d = f / fn * length * min(max(0.3 * fn, 0.05), 0.4)
                ax.annotate(
                    "",
                    xy=(pos[0, c] + d[c], pos[0, 2] + d[2]),
                    xytext=(pos[0, c], pos[0, 2]),
                    arrowprops={"arrowstyle": "-|>", "color": "k", "lw": 2},
                )
        temps = " ".join(f"{t:4.0f}" for t in s["temperature"])
        volts = " ".join(f"{v:4.2f}" for v in s["voltage"])
        self._text.set_text(
            f"t = {s['time']:6.1f} s   target {np.array2string(target, precision=1)}\n"
            f"T [K] {temps}\nV [V] {volts}"
        )
        canvas = self._fig.canvas
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()

    def close(self):
        self._fig = None
