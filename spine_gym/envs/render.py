"""``render_mode="rgb_array"`` frames of the spine (matplotlib; this module is imported on the
first ``render()`` so that ``import spine_gym`` stays free of matplotlib).

The centre line comes from :func:`spine_gym.physics.planar.tube.vertices` (the model's own geometry);
the two wires are drawn at the offset ``a`` on either side and coloured by their temperature on a
scale from the ambient temperature to ``temperature_limit`` (the colour bar on the right, with a
mark at each wire's temperature); the target is drawn as a dashed circular arc of the spine's
length that turns by the target angle; an active tip force (plus payload weight) is an arrow on the
top disk, 0.3 spine lengths per newton. Time, angle, target, wire temperatures and voltages are
printed in the top-left corner; a legend names the target, the force arrow and the temperature
limit (the top of the colour bar). The artists are made once; per frame only the moving ones are
drawn over a saved background (redrawn when the temperature scale or the spine length changes).

The spatial envs (``SmaSpine3D``, ``SmaSpineChain``) get :class:`SpatialRenderer`: a perspective
view of the centre line with each wire in its own colour map, a top view of the tip with its
recent path and the target, a legend, and bars of the wire temperatures [K] with the voltages [V].
Both renderers only read the state summary: rendering changes no observation, reward or random
stream. ``panel_boxes()`` gives each panel's pixel box in a frame.
"""

from __future__ import annotations

import math
from collections import deque

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers the "3d" projection)

from ..physics import columns as L
from ..physics.planar.tube import vertices
from ..physics.spatial import columns as SL
from ..physics.spatial.tube import kinematics, positions
from .targets_spatial import arc_positions

FRAME_SIZE = (480, 480)  # [px] width, height
CMAP = "coolwarm"  # wire colour: blue at ambient, red at the temperature limit
TARGET_COLOR = "tab:green"
PATH_COLOR = "tab:purple"
FORCE_COLOR = "k"
LIMIT_COLOR = "tab:red"
FORCE_SCALE = 0.3  # [spine lengths per N] tip-force arrow length


PLANAR_BOX = (0.0, 0.0, 0.8, 1.0)  # figure fractions (left, bottom, width, height): the spine
PLANAR_SCALE_BOX = (0.83, 0.25, 0.035, 0.6)  # the temperature colour bar


def pixel_boxes(size: tuple[int, int], boxes: dict) -> dict[str, tuple[int, int, int, int]]:
    """Pixel boxes ``(row0, row1, col0, col1)`` (rows from the top) of figure-fraction boxes."""
    w, h = size
    return {
        name: (round(h * (1 - y - bh)), round(h * (1 - y)), round(w * x), round(w * (x + bw)))
        for name, (x, y, bw, bh) in boxes.items()
    }


def planar_legend(temperature_limit: float) -> list[Line2D]:
    """Legend handles of the planar frame: target, tip force and the temperature limit."""
    return [
        Line2D([], [], ls="--", color=TARGET_COLOR, lw=2, label="target (arc of the target angle)"),
        Line2D([], [], color=FORCE_COLOR, marker=">", ms=5, label=f"tip force ({FORCE_SCALE:g} L per N)"),
        Line2D([], [], color=LIMIT_COLOR, ls=":", lw=2, label=f"temperature limit {temperature_limit:.0f} K"),
    ]


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
        self._ax = ax = fig.add_axes(PLANAR_BOX)
        ax.set_aspect("equal")
        ax.axis("off")
        ax.axhline(0.0, color="0.3", lw=3)
        self._cmap = matplotlib.colormaps[CMAP]
        (self._target,) = ax.plot([], [], ls="--", color=TARGET_COLOR, lw=2)
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
        ax.legend(handles=planar_legend(self.temperature_limit), loc="lower left", fontsize=7, frameon=False)
        # temperature scale of the wire colours, with a mark per wire
        cax = fig.add_axes(PLANAR_SCALE_BOX)
        self._scale = ScalarMappable(Normalize(0.0, 1.0), self._cmap)
        bar = fig.colorbar(self._scale, cax=cax)
        bar.ax.tick_params(labelsize=7)
        bar.set_label("wire temperature [K] (R = right, L = left wire)", fontsize=7)
        top = {"color": LIMIT_COLOR, "transform": cax.transAxes}  # the top of the scale is the limit
        cax.plot([-0.3, 1.3], [1.0, 1.0], ls=":", lw=2.5, clip_on=False, **top)
        cax.text(0.5, 1.01, "limit", ha="center", va="bottom", fontsize=7, **top)
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

    def panel_boxes(self) -> dict[str, tuple[int, int, int, int]]:
        """Pixel boxes ``(row0, row1, col0, col1)`` of the panels in a frame (rows from the top)."""
        return pixel_boxes(self.size, {"spine": PLANAR_BOX, "scale": PLANAR_SCALE_BOX})

    def _update_background(self, key: tuple[float, float, float]) -> None:
        """Redraw the static parts (axes limits, colour scale, legend, base) if ``key`` changed."""
        if key == self._background_key:
            return
        t_lo, t_hi, length = key
        half = 0.62 * length
        self._ax.set_xlim(-half, half)
        self._ax.set_ylim(-0.4 * length, 1.12 * length)  # the legend sits below the base
        self._scale.set_clim(t_lo, t_hi)
        canvas = self._fig.canvas
        canvas.draw()
        self._background = canvas.copy_from_bbox(self._fig.bbox)
        self._background_key = key

    def draw(self, s: dict, slot: int = 0) -> np.ndarray:
        """Frame (H, W, 3) uint8 of a :meth:`SpineBatch.state_summary` dict (``slot``, the
        environment's index in a vector env, is unused: the planar frame keeps no history)."""
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
            d = f / fn * length * min(max(FORCE_SCALE * fn, 0.05), 0.4)  # clipped to 0.05-0.4 L
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
    :class:`SpatialRenderer` (``SmaSpine3D``, ``SmaSpineChain``)."""
    if hasattr(cfg, "layout"):
        return SpatialRenderer(cfg.temperature_limit)
    return SpineRenderer(cfg.temperature_limit)


# spatial frame layout, figure fractions (left, bottom, width, height)
BOX_3D = (0.075, 0.28, 0.55, 0.68)  # perspective view
BOX_TOP = (0.605, 0.50, 0.31, 0.37)  # top view (x-y)
BOX_LEGEND = (0.61, 0.30, 0.39, 0.15)  # legend of the symbols
BOX_WIRES = (0.085, 0.055, 0.9, 0.2)  # wire temperature bars with voltages
HISTORY = 60  # [frames] tip path kept per environment (6 s at the default 0.1 s control period)
WIRE_CMAPS = ("Blues", "Oranges", "Greens", "Purples")  # wire at azimuth ψ = 90° j uses map j
CMAP_SPAN = (0.35, 1.0)  # [-] part of each map used: ambient → temperature limit
VIEW_ELEV, VIEW_AZIM, VIEW_ZOOM = 18.0, -60.0, 1.2  # [deg], [deg], [-] of the perspective view
ZAXIS_SIDE = "lower"  # z ticks on the left, away from the top view
PORE_R = 0.92  # [-] radius of the pore marks in the top view, a fraction of its half-width


def pore_index(kw: np.ndarray, j: int) -> int:
    """Pore of wire ``j`` in its module: 0 … 3 for the azimuth ψ = 0°, 90°, 180°, 270°."""
    psi = math.degrees(math.atan2(-kw[j, SL.W_EX], kw[j, SL.W_EY])) % 360.0
    return round(psi / 90.0) % 4


def wire_labels(kw: np.ndarray) -> list[str]:
    """Short names of the wires: ``w0`` … ``w3`` (one module) or ``m1 w0`` … (module 1 = bottom)."""
    one_module = int(kw[:, SL.W_MOD].max()) == 0
    return [
        f"w{pore_index(kw, j)}" if one_module else f"m{int(kw[j, SL.W_MOD]) + 1} w{pore_index(kw, j)}"
        for j in range(kw.shape[0])
    ]


def wire_color(j: int, kw: np.ndarray, level: float):
    """RGBA of wire ``j`` at temperature ``level`` ∈ [0, 1] (0 ambient, 1 limit) on its own map."""
    cmap = matplotlib.colormaps[WIRE_CMAPS[pore_index(kw, j)]]
    lo, hi = CMAP_SPAN
    return cmap(lo + (hi - lo) * float(np.clip(level, 0.0, 1.0)))


def spatial_geometry(s: dict) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """Centre line P_0 (tip) … P_N (base) [mm], section frames (rows d1, d2, t) and each wire's
    polyline [mm] (its pore at a·(cos ψ d1 + sin ψ d2) beside its module's vertices)."""
    km, kw = s["km"], s["kw"]
    ns = s["omega"].shape[0]
    frames = np.empty((ns + 1, 3, 3))
    chords = np.empty((ns, 3))
    pos = np.empty((ns + 1, 3))
    kinematics(np.ascontiguousarray(s["omega"]), km, frames, chords)
    positions(chords, pos)
    wires = []
    for j in range(kw.shape[0]):
        k = int(kw[j, SL.W_MOD])
        s0, nk = int(km[k, SL.M_SEG0]), int(km[k, SL.M_NSEG])
        fr = frames[s0 : s0 + nk + 1]
        off = kw[j, SL.W_A] * (kw[j, SL.W_EY] * fr[:, 0] - kw[j, SL.W_EX] * fr[:, 1])
        wires.append(1000.0 * (pos[s0 : s0 + nk + 1] + off))
    return 1000.0 * pos, frames, wires


def target_points(s: dict) -> np.ndarray:
    """The target drawn in the views [mm]: the arc of a one-module bending target (tip first), or
    the single point of a tip-position target."""
    target = np.asarray(s["target"], dtype=float)
    if s["task"] == "tip_bending_deg":
        km = s["km"]
        return arc_positions(np.repeat(target[None, :], km.shape[0], axis=0), km)
    return target[None, :]


def bend_text(t: np.ndarray) -> str:
    """Polar angle and azimuth [deg] of a tip tangent ``t``, as the bending vector (b1, b2)."""
    theta = math.degrees(math.acos(float(np.clip(t[2], -1.0, 1.0))))
    psi = math.degrees(math.atan2(t[1], t[0]))
    return f"{theta:4.1f}° toward {psi:+4.0f}°"


def force_arrow(force: np.ndarray, length: float) -> np.ndarray:
    """Arrow [mm] of a tip force [N]: :data:`FORCE_SCALE` spine lengths per newton, clipped to
    0.05-0.4 spine lengths so that small forces stay visible; zero without a force."""
    fn = float(np.linalg.norm(force))
    return force / fn * length * min(max(FORCE_SCALE * fn, 0.05), 0.4) if fn > 1e-9 else 0.0 * force


def spatial_legend(t_hi: float, bending: bool) -> list[Line2D]:
    """Legend handles of the spatial frame: target, tip path, tip force, temperature limit."""
    target = "target bend (arc) and tip" if bending else "target tip position"
    style = "--" if bending else ""  # an arc only for a bending target
    edge = {"mec": "k", "mew": 0.5}
    return [
        Line2D([], [], color=TARGET_COLOR, ls=style, marker="*", ms=8, label=target, **edge),
        Line2D([], [], color=PATH_COLOR, marker="o", ms=4, label=f"tip, its last {HISTORY} steps", **edge),
        Line2D([], [], color=FORCE_COLOR, marker=">", ms=5, label=f"tip force ({FORCE_SCALE:g} L per N)"),
        Line2D([], [], color=LIMIT_COLOR, ls=":", lw=1.5, label=f"temperature limit {t_hi:.0f} K"),
    ]


def header_text(s: dict, tip: np.ndarray, tangent: np.ndarray) -> str:
    """Two lines: time, target and the tip's state, with units."""
    target = np.asarray(s["target"], dtype=float)
    if s["task"] == "tip_bending_deg":
        b = math.hypot(*target)
        psi = math.degrees(math.atan2(target[1], target[0]))
        return (
            f"t = {s['time']:5.1f} s   target bend {b:4.1f}° toward azimuth {psi:+4.0f}°"
            f"  (b₁ {target[0]:+.1f}°, b₂ {target[1]:+.1f}°)\n"
            f"tip bend {bend_text(tangent)}   tip x {tip[0]:+.0f} mm, y {tip[1]:+.0f} mm"
        )
    return (
        f"t = {s['time']:5.1f} s   target tip x {target[0]:+.0f}, y {target[1]:+.0f}, "
        f"z {target[2]:.0f} mm\n"
        f"tip x {tip[0]:+.0f}, y {tip[1]:+.0f}, z {tip[2]:.0f} mm   "
        f"error {np.linalg.norm(tip - target):.1f} mm"
    )


class SpatialRenderer:
    """Frames of a spatial spine, 480 × 480 px, in four panels:

    * a perspective view (top left) of the centre line (grey) with each wire drawn in its own
      colour map (blue, orange, green, purple for the pores at ψ = 0°, 90°, 180°, 270°; pale at
      ambient, dark at ``temperature_limit``), its shadow on the base plane, the target (dashed
      arc of a bending target or a star at a target tip position), the tip's recent path and the
      force on the top disk (arrow, 0.3 spine lengths per newton);
    * a top view (top right, x-y [mm]) of the tip, its path over the last :data:`HISTORY` frames,
      the target tip, the horizontal part of the force and the wire pores at the base (labelled);
    * a legend of these symbols;
    * the wire temperatures [K] as bars in each wire's colour with the temperature limit
      (dotted, labelled) and each wire's voltage [V] under its name.

    The tip path is kept per environment (``slot``) and restarts when the time goes back (a
    reset); a second frame of the same time replaces the last point. Drawing only reads the
    state summary.
    """

    def __init__(self, temperature_limit: float, size: tuple[int, int] = FRAME_SIZE):
        self.temperature_limit = float(temperature_limit)
        self.size = size
        self._fig = None
        self._paths: dict[int, deque] = {}

    def _setup(self, s: dict) -> None:
        """Figure, panels and every artist (updated in place per frame: no axes is cleared)."""
        dpi = 100
        self._fig = fig = Figure(figsize=(self.size[0] / dpi, self.size[1] / dpi), dpi=dpi)
        FigureCanvasAgg(fig)
        self._text = fig.text(0.01, 0.995, "", va="top", ha="left", fontsize=7.5)
        length = 1000.0 * s["length"]
        self._setup_3d(fig.add_axes(BOX_3D, projection="3d"), s, length)
        self._setup_top(fig.add_axes(BOX_TOP), s)
        self._setup_bars(fig.add_axes(BOX_WIRES), s)
        legend = fig.add_axes(BOX_LEGEND)
        legend.axis("off")
        t_hi = max(self.temperature_limit, s["ambient"] + 1.0)
        legend.legend(handles=spatial_legend(t_hi, s["task"] == "tip_bending_deg"), loc="center",
                      fontsize=6.5, frameon=False, handlelength=2.2)  # fmt: skip

    def _setup_3d(self, ax, s: dict, length: float) -> None:
        self._ax3 = ax
        half = 0.6 * length
        ax.set_xlim(-half, half)
        ax.set_ylim(-half, half)
        ax.set_zlim(0.0, 1.05 * length)
        ax.set_box_aspect((1.0, 1.0, 0.875), zoom=VIEW_ZOOM)
        ax.view_init(elev=VIEW_ELEV, azim=VIEW_AZIM)
        ax.tick_params(labelsize=5.5, pad=-2)
        for axis, name in ((ax.xaxis, "x [mm]"), (ax.yaxis, "y [mm]"), (ax.zaxis, "")):
            axis.set_major_locator(MaxNLocator(3))
            axis.set_label_text(name, fontsize=6.5)
            axis.labelpad = -6
        ax.zaxis.set_ticks_position(ZAXIS_SIDE)
        ax.text2D(0.0, 0.78, "z [mm]", transform=ax.transAxes, rotation=90, fontsize=6.5, va="center")
        ring = np.linspace(0.0, 2.0 * np.pi, 60)
        ax.plot(0.4 * half * np.cos(ring), 0.4 * half * np.sin(ring), 0.0 * ring, color="0.4", lw=1.5)
        (self._shadow,) = ax.plot([], [], [], color="0.8", lw=4, solid_capstyle="round")
        (self._spine,) = ax.plot([], [], [], color="0.6", lw=7, solid_capstyle="round")
        self._wires3 = [ax.plot([], [], [], lw=2.2)[0] for _ in range(s["kw"].shape[0])]
        (self._target3,) = ax.plot([], [], [], ls="--", color=TARGET_COLOR, lw=1.8)
        (self._target3_tip,) = ax.plot([], [], [], marker="*", ms=9, color=TARGET_COLOR, mec="k", mew=0.5)
        (self._path3,) = ax.plot([], [], [], color=PATH_COLOR, lw=1.2)
        self._force3 = None

    def _setup_top(self, ax, s: dict) -> None:
        self._top = ax
        ax.set_aspect("equal")
        ax.tick_params(labelsize=6, pad=1)
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.yaxis.set_major_locator(MaxNLocator(4))
        ax.set_xlabel("x [mm]", fontsize=6.5, labelpad=0)
        ax.set_ylabel("y [mm]", fontsize=6.5, labelpad=1)
        ax.yaxis.tick_right()
        ax.yaxis.set_label_position("right")  # away from the perspective view's z axis
        ax.set_title("top view of the tip", fontsize=7, pad=2)
        ax.grid(alpha=0.3, lw=0.5)
        kw = s["kw"]
        self._pores = []  # (cos ψ, sin ψ, mark, label) of the bottom module's wires (same ψ above)
        for j in (j for j in range(kw.shape[0]) if int(kw[j, SL.W_MOD]) == 0):
            psi = math.atan2(-kw[j, SL.W_EX], kw[j, SL.W_EY])
            mark = ax.plot([], [], "o", ms=4, color=wire_color(j, kw, 0.8))[0]
            label = ax.text(0.0, 0.0, f"w{pore_index(kw, j)}", fontsize=6, ha="center", va="center")
            self._pores.append((math.cos(psi), math.sin(psi), mark, label))
        (self._target_top,) = ax.plot([], [], marker="*", ms=11, color=TARGET_COLOR, mec="k", mew=0.5)
        (self._path_top,) = ax.plot([], [], color=PATH_COLOR, lw=1.2)
        (self._tip_top,) = ax.plot([], [], "o", color=PATH_COLOR, ms=5, mec="k", mew=0.5)
        arrow = {"arrowstyle": "-|>", "color": FORCE_COLOR, "lw": 1.5}
        self._force_top = ax.annotate("", xy=(0.0, 0.0), xytext=(0.0, 0.0), arrowprops=arrow)
        self._top_lim = None

    def _setup_bars(self, ax, s: dict) -> None:
        self._bars_ax = ax
        n = s["kw"].shape[0]
        t_lo, t_hi = s["ambient"], max(self.temperature_limit, s["ambient"] + 1.0)
        self._bars = ax.bar(np.arange(n), np.zeros(n), bottom=t_lo, width=0.7, edgecolor="0.3", lw=0.5)
        self._bar_text = [ax.text(j, t_lo, "", ha="center", va="bottom", fontsize=6) for j in range(n)]
        self._limit_line = ax.axhline(t_hi, color=LIMIT_COLOR, ls=":", lw=1.5)
        self._limit_text = ax.text(n - 0.5, t_hi, "", color=LIMIT_COLOR, ha="right", va="bottom", fontsize=6)
        ax.set_xlim(-0.5, n - 0.5)
        ax.tick_params(labelsize=6, pad=1)
        ax.set_ylabel("T [K]", fontsize=6.5, labelpad=1)
        title = "wire temperature (bar; each wire's colour pale at ambient, dark at the limit), voltage"
        ax.text(1.0, 1.0, title, transform=ax.transAxes, ha="right", va="bottom", fontsize=6.5)
        ax.set_xticks(np.arange(n))

    def panel_boxes(self) -> dict[str, tuple[int, int, int, int]]:
        """Pixel boxes ``(row0, row1, col0, col1)`` of the panels in a frame (rows from the top)."""
        boxes = {"3d": BOX_3D, "top": BOX_TOP, "legend": BOX_LEGEND, "wires": BOX_WIRES}
        return pixel_boxes(self.size, boxes)

    def _tip_path(self, slot: int, time: float, tip: np.ndarray) -> np.ndarray:
        path = self._paths.get(slot)
        if path is None or not path or time < path[-1][0]:
            path = self._paths[slot] = deque(maxlen=HISTORY)
        if path and time == path[-1][0]:
            path.pop()  # the same state drawn again
        path.append((time, tip.copy()))
        return np.array([p for _, p in path])

    def draw(self, s: dict, slot: int = 0) -> np.ndarray:
        """Frame (H, W, 3) uint8 of a :meth:`SpatialBatch.state_summary` dict; ``slot`` names the
        environment whose tip path to extend (vector envs)."""
        if self._fig is None:
            self._setup(s)
        pos, frames, wires = spatial_geometry(s)
        path = self._tip_path(slot, float(s["time"]), pos[0])
        t_lo, t_hi = s["ambient"], max(self.temperature_limit, s["ambient"] + 1.0)
        levels = (np.asarray(s["temperature"], dtype=float) - t_lo) / (t_hi - t_lo)
        target = target_points(s)
        length = 1000.0 * s["length"]
        arrow = force_arrow(np.asarray(s["tip_force"], dtype=float), length)
        self._draw_3d(s["kw"], pos, wires, levels, target, path, arrow)
        self._draw_top(pos, target, path, arrow, length)
        self._draw_bars(s, t_lo, t_hi, levels)
        self._text.set_text(header_text(s, pos[0], frames[0, 2]))
        canvas = self._fig.canvas
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()

    def _draw_3d(self, kw, pos, wires, levels, target, path, arrow) -> None:
        self._shadow.set_data_3d(pos[:, 0], pos[:, 1], 0.0 * pos[:, 2])
        self._spine.set_data_3d(pos[:, 0], pos[:, 1], pos[:, 2])
        for j, (line, w) in enumerate(zip(self._wires3, wires, strict=True)):
            line.set_data_3d(w[:, 0], w[:, 1], w[:, 2])
            line.set_color(wire_color(j, kw, levels[j]))
        arc = target if target.shape[0] > 1 else target[:0]
        self._target3.set_data_3d(arc[:, 0], arc[:, 1], arc[:, 2])
        self._target3_tip.set_data_3d(target[:1, 0], target[:1, 1], target[:1, 2])
        self._path3.set_data_3d(path[:, 0], path[:, 1], path[:, 2])
        if self._force3 is not None:
            self._force3.remove()
            self._force3 = None
        if np.any(arrow):
            self._force3 = self._ax3.quiver(
                *pos[0], *arrow, color=FORCE_COLOR, lw=1.8, arrow_length_ratio=0.3
            )  # a new artist per frame: a 3-D quiver has no setter for its data

    def _draw_top(self, pos, target, path, arrow, length: float) -> None:
        reach = max(0.25 * length, float(np.abs(path[:, :2]).max()), float(np.abs(target[0, :2]).max()))
        lim = 10.0 * math.ceil(1.3 * reach / 10.0)  # [mm] half-width: the tip stays inside the pore marks
        if lim != self._top_lim:
            self._set_top_limits(lim)
        self._target_top.set_data(target[:1, 0], target[:1, 1])
        self._path_top.set_data(path[:, 0], path[:, 1])
        self._tip_top.set_data(pos[:1, 0], pos[:1, 1])
        self._force_top.set_visible(np.hypot(arrow[0], arrow[1]) > 1e-3 * length)
        self._force_top.xy = tuple(pos[0, :2] + arrow[:2])
        self._force_top.set_position(tuple(pos[0, :2]))

    def _set_top_limits(self, lim: float) -> None:
        """Axis limits ±``lim`` [mm] and the pore marks at the edge of the top view."""
        self._top.set_xlim(-lim, lim)
        self._top.set_ylim(-lim, lim)
        for c, sn, mark, label in self._pores:
            mark.set_data([PORE_R * lim * c], [PORE_R * lim * sn])
            label.set_position((PORE_R * lim * c - 0.12 * lim * sn, PORE_R * lim * sn + 0.12 * lim * c))
        self._top_lim = lim

    def _draw_bars(self, s, t_lo: float, t_hi: float, levels: np.ndarray) -> None:
        kw = s["kw"]
        temps = np.asarray(s["temperature"], dtype=float)
        for j, (bar, txt) in enumerate(zip(self._bars, self._bar_text, strict=True)):
            bar.set_y(t_lo)
            bar.set_height(temps[j] - t_lo)
            bar.set_facecolor(wire_color(j, kw, levels[j]))
            txt.set_position((j, temps[j]))
            txt.set_text(f"{temps[j]:.0f} K")
        self._limit_line.set_ydata([t_hi, t_hi])
        self._limit_text.set_y(t_hi)
        self._limit_text.set_text(f"limit {t_hi:.0f} K ")
        top = max(t_hi, float(temps.max())) + 0.25 * (t_hi - t_lo)
        self._bars_ax.set_ylim(t_lo - 0.02 * (t_hi - t_lo), top)
        names = [f"{n}\n{v:.2f} V" for n, v in zip(wire_labels(kw), s["voltage"], strict=True)]
        self._bars_ax.set_xticklabels(names)

    def close(self) -> None:
        self._fig = None
        self._paths.clear()
