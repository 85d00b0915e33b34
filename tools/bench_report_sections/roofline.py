"""The roofline: the peaks measured, and where the kernels sit against them."""
import os

import matplotlib.pyplot as plt

from .common import fmt, table


def write(md, inputs):
    """Appends the section to md (a list of markdown lines)."""
    plots, rf = inputs.plots, inputs.rf
    md.append("## Roofline\n")
    md.append(
        "`bench/bench_roofline.cpp`. Peaks measured on this machine (the VM exposes neither the clock nor "
        "hardware counters): FMA throughput from 12 (AVX2) or 24 (AVX-512) independent register "
        "accumulators per thread (2 flops per lane per FMA); memory bandwidth from STREAM's triad over "
        "3 x 128 MiB (24 bytes per element, STREAM's convention). Kernel flops: the axis/angle fit's are "
        f"counted ({fmt(rf.context.get('fit_flops_counted') and float(rf.context['fit_flops_counted']))} "
        "flops per fit, mean over the benchmark matrices, by running the scalar reference on an "
        "instrumented scalar type: `bench/flop_count.hpp`); the deformer's correlation sums are nominal "
        "(24 flops per vertex and handle precomputed, 40 on the fly). Bytes: the fit reads and writes 72 "
        "per fit; a frame reads `memory_bytes()` and writes 12 per vertex.\n"
    )
    rows = []
    peak = {}
    for nm in sorted(rf.names("peak/")):
        b = rf.get(nm)
        g = b.get("GFLOPs")
        bw = b.get("GBs")
        # The counters are already in GFLOP/s and GB/s (the programs scale them by 1e-9).
        rows.append([f"`{nm}`", fmt(g) if g and not bw else "", fmt(bw) if bw else ""])
        peak[nm] = (g if g and not bw else None, bw if bw else None)
    md.append(table(["peak", "GFLOP/s", "GB/s"], rows))
    md.append("")
    fl1 = max([v[0] for k, v in peak.items() if "fma/float" in k and k.endswith("threads:1") and v[0]] or [0])
    fln = max([v[0] for k, v in peak.items() if "fma/float" in k and v[0]] or [0])
    bw1 = max([v[1] for k, v in peak.items() if "triad/threads:1" in k and v[1]] or [0])
    bwn = max([v[1] for k, v in peak.items() if "triad" in k and v[1]] or [0])
    rows = []
    pts = []
    for nm in sorted(rf.names("kernel/")):
        b = rf.get(nm)
        g, bw = b.get("GFLOPs", 0), b.get("GBs", 0)
        multi = "threads:" in nm or nm.startswith("kernel/deform")
        fpk, bpk = (fln, bwn) if multi else (fl1, bw1)
        ai = g / bw if bw else None
        rows.append(
            [
                f"`{nm}`",
                "all" if multi else "1",
                fmt(g),
                fmt(100 * g / fpk if fpk else None) + "%",
                fmt(bw),
                fmt(100 * bw / bpk if bpk else None) + "%",
                fmt(ai),
            ]
        )
        pts.append((nm, ai, g, multi))
    md.append(table(["kernel", "threads", "GFLOP/s", "of FMA peak", "GB/s", "of triad", "flop/byte"], rows))
    md.append("")
    md.append(
        "The triad peak is main-memory bandwidth (its arrays are 12 times the L3). A kernel whose data fit "
        "in the 32 MiB L3 (the Bar table: 24 MiB) streams from cache and can exceed it; the 10^6-vertex "
        "table (175 MiB) cannot.\n"
    )
    if fl1 and bw1 and pts:
        fig, ax = plt.subplots(figsize=(7, 5))
        x = [10 ** (i / 10) for i in range(-20, 31)]
        for fp, bp, lab, ls in [(fl1, bw1, "1 core", "-"), (fln, bwn, "all cores", "--")]:
            ax.loglog(
                x,
                [min(fp, bp * xi) for xi in x],
                "k" + ls,
                linewidth=1,
                label=f"roof, {lab} ({fmt(fp)} GFLOP/s, {fmt(bp)} GB/s)",
            )
        for nm, ai, g, multi in pts:
            if ai:
                ax.loglog([ai], [g], "o" if not multi else "s", label=nm.replace("kernel/", ""))
        ax.set_xlabel("arithmetic intensity (flop/byte)")
        ax.set_ylabel("GFLOP/s")
        ax.set_title("roofline (float FMA peak, STREAM triad)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(plots, "roofline.png"), dpi=110)
        plt.close(fig)
        md.append("![roofline](plots/roofline.png)\n")
