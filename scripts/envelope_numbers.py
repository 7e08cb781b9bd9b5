"""The numbers behind the actuator envelope (docs/envelope.md), from the model itself.

Per drive voltage (one wire of the planar pair at it from cold, its antagonist at 0 V): the wire's
current and Joule power in martensite and austenite, its adiabatic heating rate, the steady
temperature without a cut-off, the time to the transformation (50 % austenite) and to the cut-off,
and the largest overshoot above the cut-off within one control period on the ``-v2`` plant
(:mod:`spine_gym.envelope`). Writes a PNG of the wire temperature against time with and without the
cut-off::

    python scripts/envelope_numbers.py [--png docs/images/envelope_temperatures.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from spine_gym.envelope import cutoff_drive, electrics, step_drive
from spine_gym.envs.ids import CUTOFF_MARGIN_K, TEMPERATURE_LIMIT_K

VOLTS = (3.2, 4.0, 5.0, 6.0, 8.0)
CUTOFF = TEMPERATURE_LIMIT_K - CUTOFF_MARGIN_K
PNG = Path(__file__).resolve().parents[1] / "docs" / "images" / "envelope_temperatures.png"


def table(volts=VOLTS) -> tuple[list[str], list[list[str]], dict]:
    """The header, the rows (text) and the runs behind them."""
    head = [
        "V [V]",
        "I M/A [A]",
        "P M/A [W]",
        "dT/dt adiabatic M/A [K/s]",
        "T steady, no cut-off [K]",
        "t to 50 % austenite [s]",
        f"t to {CUTOFF:g} K [s]",
        "max T with cut-off [K]",
        "overshoot [K]",
    ]
    rows, runs = [], {}
    for v in volts:
        e, s = electrics(v), step_drive(v)
        t_cut, temp_cut = cutoff_drive(v, CUTOFF)
        t_free, temp_free = cutoff_drive(v, None)
        runs[v] = (t_cut, temp_cut, t_free, temp_free)
        peak = float(temp_cut.max())
        rows.append(
            [
                f"{v:g}",
                f"{e.i_m:.2f} / {e.i_a:.2f}",
                f"{e.p_m:.2f} / {e.p_a:.2f}",
                f"{e.heating_m:.1f} / {e.heating_a:.1f}",
                f"{s.t_steady:.0f}",
                f"{s.time_to_transformation():.2f}",
                f"{s.time_to(CUTOFF):.2f}",
                f"{peak:.3f}",
                f"{peak - CUTOFF:+.2f}",
            ]
        )
    return head, rows, runs


def plot(runs: dict, path: Path) -> None:
    """Left: the whole minute (dashed: no cut-off); right: the same near the cut-off."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), dpi=120)
    for ax, zoom in zip(axes, (False, True), strict=True):
        for k, (v, (t_cut, temp_cut, t_free, temp_free)) in enumerate(runs.items()):
            ax.plot(t_free, temp_free, color=f"C{k}", ls="--", lw=1.1)
            marker = "." if zoom else None
            ax.plot(t_cut, temp_cut, color=f"C{k}", lw=1.6, marker=marker, ms=3, label=f"{v:g} V")
        ax.axhline(TEMPERATURE_LIMIT_K, color="k", ls=":", lw=1.0, label=f"limit {TEMPERATURE_LIMIT_K:g} K")
        ax.axhline(CUTOFF, color="0.4", ls="-.", lw=1.0, label=f"cut-off {CUTOFF:g} K")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("driven wire temperature [K]")
        ax.grid(alpha=0.3)
        if zoom:
            ax.set_xlim(0, 30)
            ax.set_ylim(CUTOFF - 8, TEMPERATURE_LIMIT_K + 4)
            ax.set_title("near the cut-off (one point per 0.1-s control period)", fontsize=9)
        else:
            ax.set_xlim(0, max(t[-1] for t, *_ in runs.values()))
            ax.set_ylim(280, None)
            ax.set_title("solid: with the driver's cut-off; dashed: without", fontsize=9)
            ax.legend(title="drive voltage", fontsize=8, title_fontsize=8, loc="upper left")
    title = "One wire of the planar pair at a constant voltage from cold (SmaSpineEasy-v2 plant)"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--png", type=Path, default=PNG, help="where to write the figure")
    args = parser.parse_args(argv)
    e = electrics(5.0)
    print(
        f"wire: R martensite {e.r_m:.3f} Ohm, austenite {e.r_a:.3f} Ohm; "
        f"thermal time constant {e.tau_th:.1f} s"
    )
    head, rows, runs = table()
    print("| " + " | ".join(head) + " |")
    print("|" + "|".join("--:" for _ in head) + "|")
    for r in rows:
        print("| " + " | ".join(r) + " |")
    steady = {v: (electrics(v).t_steady_m, electrics(v).t_steady_a) for v in VOLTS}
    cells = ", ".join(f"{v:g} V {m:.0f} / {a:.0f}" for v, (m, a) in steady.items())
    print(f"steady temperature without latent heat, martensite / austenite [K]: {cells}")
    plot(runs, args.png)
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
