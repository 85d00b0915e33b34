"""The rotation fit: ns per fit by method and instruction set, and the error sweep plot."""
import csv
import os

import matplotlib.pyplot as plt

from .common import METHODS, METHOD_NOTES, fmt, count, ratio, table


def write(md, inputs):
    """Appends the section to md (a list of markdown lines)."""
    best_isa = inputs.best_isa
    res, plots, rot = inputs.res, inputs.plots, inputs.rot
    md.append("## Rotation fit: ns per fit\n")
    md.append(
        f"`bench/bench_rotation_fit.cpp`: the same {count(rot.context.get('cases'))} random correlation matrices "
        f"for every method ({count(rot.context.get('cases_det_negative'))} with det H < 0; seed "
        f"{rot.context.get('case_seed', '?')}), one core. `scalar` is `fit_rotation` one matrix at a time "
        "(the library's scalar reference, baseline x86-64 flags; QCP is `bench/qcp.hpp`); `batch:<isa>` "
        "is `fit_rotations` on the structure-of-arrays set, forced to that ISA. Streamed: the whole set "
        "from memory; hot: the first 4,096 matrices repeated (in L2, as in the deformer, which builds "
        "each H in registers). Checks: every result against the long-double SVD reference with the accuracy "
        "suite's bounds (`tests/support/accuracy_bounds.hpp`: backward-error constant c_b = 16 for every "
        "method); QCP with c_b = 16 plus the error of a root taken from the "
        "polynomial's coefficients (`bench/reference.hpp`). Worst err/tol: the largest ratio of error to "
        "bound over all checks (<= 1 to pass).\n"
    )
    rows = []
    for m in METHODS:
        row = [f"`{m}`", METHOD_NOTES[m]]
        for t in ["float", "double"]:
            name = f"fit/{t}/{m}/scalar"
            ns = rot.get(name, "ns_per_fit")
            row.append(fmt(ns) if ns else ("skipped" if name in rot.errors else "n/a"))
        for t in ["float", "double"]:
            w = rot.get(f"fit/{t}/{m}/scalar", "worst_err_over_tol")
            row.append(fmt(w, 2) if w is not None else "n/a")
        rows.append(row)
    md.append(
        table(["method", "", "float ns/fit", "double ns/fit", "float worst err/tol", "double worst err/tol"], rows)
    )
    md.append("")
    isas = [
        i
        for i in ["scalar", "sse4_2", "avx2", "avx512"]
        if any(n.endswith("batch:" + i) for n in list(rot.by_name) + list(rot.errors))
    ]
    if isas:
        md.append("### Batched (`fit_rotations`), ns per fit, one thread\n")
        rows = []
        for m in ["axis_angle", "horn_quaternion"]:
            for t in ["float", "double"]:
                for kind in ["fit_hot", "fit", "gauss_hot", "gauss"]:
                    row = [
                        f"`{m}`",
                        t,
                        {
                            "fit_hot": "points, hot",
                            "fit": "points, streamed",
                            "gauss_hot": "Gaussian, hot",
                            "gauss": "Gaussian, streamed",
                        }[kind],
                    ]
                    for isa in isas:
                        name = f"{kind}/{t}/{m}/batch:{isa}"
                        ns = rot.get(name, "ns_per_fit")
                        row.append(fmt(ns) if ns else ("skipped" if name in rot.errors else "n/a"))
                    rows.append(row)
        md.append(table(["method", "type", "set"] + isas, rows))
        md.append("")
        md.append(
            "`scalar` here is the batched API looping over `fit_rotation` (MLSDEFORM_ISA=scalar). "
            "Lanes of the batched axis/angle fit that its fast path left to the careful path (Jacobi on K, "
            "in the lanes), out of "
            + count(rot.context.get("cases"))
            + " per set: "
            + "; ".join(
                f"{label} {t} {fmt(rot.get(f'{kind}/{t}/axis_angle/batch:{best_isa}', 'lanes_careful'))}"
                for kind, label in [("fit", "points"), ("gauss", "Gaussian")]
                for t in ["float", "double"]
            )
            + ".\n"
        )
        # Speed-ups
        rows = []
        for t in ["float", "double"]:
            aa = rot.get(f"fit_hot/{t}/axis_angle/batch:{best_isa}", "ns_per_fit")
            for base in ["axis_angle", "svd", "qcp"]:
                b = rot.get(f"fit/{t}/{base}/scalar", "ns_per_fit")
                r = ratio(b, aa)
                rows.append(
                    [t, f"batched axis_angle ({best_isa}, hot) vs scalar `{base}`", fmt(r) + "x" if r else "n/a"]
                )
            hj = rot.get(f"fit_hot/{t}/horn_quaternion/batch:{best_isa}", "ns_per_fit")
            r = ratio(hj, aa)
            rows.append(
                [
                    t,
                    f"batched axis_angle vs batched horn_quaternion (Jacobi), both {best_isa}",
                    fmt(r) + "x" if r else "n/a",
                ]
            )
            th = [n for n in rot.by_name if n.startswith(f"fit_hot/{t}/axis_angle/batch:{best_isa}/threads:")]
            if th and aa:
                ns2 = rot.get(th[0], "ns_per_fit")
                rows.append(
                    [t, f"both cores vs one ({th[0].split('/')[-1]}, hot)", fmt(ratio(aa, ns2)) + "x" if ns2 else "n/a"]
                )
        md.append(table(["type", "ratio", ""], rows))
        md.append("")

    # Error sweep plot
    sweep = os.path.join(res, "error_sweep.csv")
    if os.path.exists(sweep):
        data = {}
        with open(sweep) as f:
            for r in csv.DictReader(f):
                data.setdefault((r["type"], r["method"]), []).append(
                    (float(r["delta"]), float(r["median_angle_error"]), float(r["max_angle_error"]))
                )
        fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=False)
        for ax, t in zip(axes, ["float", "double"]):
            for m in METHODS + ["paper_eq14_literal"]:
                pts = sorted(data.get((t, m), []))
                if not pts:
                    continue
                style = "--" if m == "paper_eq14_literal" else "-"
                ax.loglog([p[0] for p in pts], [max(p[2], 1e-18) for p in pts], style, marker=".", label=m)
            ax.set_title(f"{t}: largest angle error of 400 fits per point")
            ax.set_xlabel("distance of the rotation angle from 180 degrees, pi - angle (rad)")
            ax.set_ylabel("angle to the long-double SVD reference (rad)")
            ax.grid(True, which="both", alpha=0.3)
        axes[0].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(plots, "error_near_half_turn.png"), dpi=110)
        plt.close(fig)
        md.append("### Accuracy near a half-turn\n")
        md.append("![error vs distance from 180 degrees](plots/error_near_half_turn.png)\n")
        md.append(
            "Point sets rotated by pi - delta about random axes (no noise, so the optimum is the generating "
            "rotation), 400 per delta; the largest angle to the long-double SVD reference of the rounded H. "
            "`paper_eq14_literal` solves the paper's (14) as written: its Gibbs vector "
            "u = e tan(angle/2) diverges as the angle nears 180 degrees (errors reach pi when the solve "
            "overflows or divides by zero), which is why the library solves (14) in a frame turned about "
            "the best axis (Shuster's sequential rotations) and stays at rounding level.\n"
        )
