"""ARAP convergence curves: energy against iterations, rigidity against time, plain and Anderson, beside CGAL.

Reads bench_quality --arap's JSON (the convergence tables: MLS + k iterations from MLS, energy / E* against
the converged result of the same energy) and bench_quality's (CGAL's ARAP on the same scenes: its default
5 iterations and its run to 500; left out where CGAL was not built). Writes plots/arap_convergence.png;
returns the markdown that shows it, or nothing where the ARAP JSON is missing.
"""
import os

import matplotlib.pyplot as plt
from matplotlib.ticker import ScalarFormatter

from .common import load

SCENES = ["human", "bar", "fish"]
SOLVERS = [("plain", "tab:blue"), ("Anderson", "tab:orange")]


def _cgal(rows, scene):
    """CGAL's default row and its long run's row for `scene` (None where CGAL was not built)."""
    default = converged = None
    for r in rows:
        if r["scene"] != scene or not r["tool"].startswith("CGAL ARAP"):
            continue
        if r["tool"].startswith("CGAL ARAP, default"):
            default = r
        else:
            converged = r
    return default, converged


def plot(res, plots):
    """Draws the curves from the JSON in `res` into `plots`; returns markdown lines (empty if no data)."""
    arap = load(os.path.join(res, "bench_quality_arap.json"))
    quality = load(os.path.join(res, "bench_quality.json")) or []
    if not arap:
        return []
    scenes = [s for s in SCENES if any(r["scene"] == s and r["table"] == "convergence" for r in arap)]
    if not scenes:
        return []
    fig, axes = plt.subplots(len(scenes), 2, figsize=(10, 3.3 * len(scenes)), squeeze=False)
    for row, scene in zip(axes, scenes):
        left, right = row
        default, converged = _cgal(quality, scene)
        for solver, colour in SOLVERS:
            pts = sorted(
                (r for r in arap if r["scene"] == scene and r["table"] == "convergence" and r["tool"] == solver),
                key=lambda r: r["iterations"],
            )
            if not pts:
                continue
            left.semilogy(
                [r["iterations"] for r in pts], [r["energy_ratio"] for r in pts], marker="o", color=colour, label=solver
            )
            ms = [r["ms_per_frame"] for r in pts]
            right.loglog(ms, [r["rigidity_p95"] for r in pts], marker="o", color=colour, label=f"{solver}: p95")
            right.loglog(
                ms,
                [r["rigidity_median"] for r in pts],
                marker="s",
                linestyle="--",
                color=colour,
                label=f"{solver}: median",
            )
        if converged:
            right.axhline(converged["rigidity_p95"], color="grey", linestyle=":", label="CGAL 500 it.: p95")
            right.axhline(converged["rigidity_median"], color="black", linestyle=":", label="CGAL 500 it.: median")
        if default:
            right.loglog(
                [default["ms_per_frame"]] * 2,
                [default["rigidity_p95"], default["rigidity_median"]],
                marker="x",
                markersize=9,
                linestyle="none",
                color="tab:red",
                label="CGAL default (5 it.): p95, median",
            )
        left.axhline(1, color="grey", linewidth=0.8)
        left.set_xlabel("ARAP iterations after MLS")
        left.set_ylabel("energy / converged energy")
        left.set_title(f"{scene}: energy")
        right.set_xlabel("ms per frame (MLS + ARAP; CGAL: one thread)")
        right.set_ylabel("rigidity")
        right.set_title(f"{scene}: rigidity against time")
        for ax in row:
            ax.grid(True, which="both", alpha=0.3)
            ax.yaxis.set_major_formatter(ScalarFormatter())
            ax.yaxis.set_minor_formatter(ScalarFormatter())
            ax.tick_params(axis="y", which="minor", labelsize=7)
    # One legend for every panel (the right column's entries include the left's colours), above the panels.
    handles, labels = axes[0][1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.45 / (3.3 * len(scenes))))
    fig.savefig(os.path.join(plots, "arap_convergence.png"), dpi=100)
    plt.close(fig)
    return [
        "The convergence tables below as curves: the energy against the iteration count (left) and the rigidity "
        "against the time per frame (right), plain and Anderson-accelerated, with CGAL's ARAP on the same scene "
        "(its default 5 iterations, and its 500-iteration run as dotted lines):\n",
        "![ARAP energy and rigidity against iterations and time, plain and Anderson, and CGAL]"
        "(plots/arap_convergence.png)\n",
    ]
