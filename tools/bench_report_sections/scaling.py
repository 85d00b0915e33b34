"""Scaling: time per frame against vertices, handles and threads."""
import os

import matplotlib.pyplot as plt

from .common import fmt, ratio, table

STORAGES = ["precomputed", "on_the_fly", "precomputed_weights"]
LABELS = {"precomputed": "precomputed", "on_the_fly": "on the fly", "precomputed_weights": "weights only"}


def write(md, inputs):
    """Appends the section to md (a list of markdown lines)."""
    plots, sc = inputs.plots, inputs.sc
    md.append("## Scaling\n")
    md.append(
        "`bench/bench_scaling.cpp`: float, `Options::isa` unset, all cores unless stated, for the three weight "
        "storages (`precomputed`: stream A_i = w_i phat_i; `on_the_fly`: recompute the weights from the "
        'distances; `precomputed_weights`, "weights only": stream w_i / S and form A_i from the handles). '
        "`memory` is `Deformer::memory_bytes()`, the precomputation's footprint. "
        "`precomputed?` is what the deformer actually did (the request may not be honoured yet).\n"
    )
    sizes = [1000, 3000, 10000, 30000, 100000, 300000, 1000000]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    rows = []
    for st in STORAGES:
        xs, ys = [], []
        for n in sizes:
            ms = sc.get(f"scaling/vertices/{st}/n:{n}", "ms_per_frame")
            if ms:
                xs.append(n), ys.append(ms)
        if xs:
            ax.loglog(xs, ys, marker="o", label=f"{st} (random box, 10 handles)")
        spot = sc.get(f"scaling/vertices/{st}/spot_loop3", "ms_per_frame")
        if spot:
            ax.loglog([737986], [spot], marker="*", markersize=12, linestyle="none", label=f"{st}: spot_loop3")
    for n in sizes + ["spot_loop3"]:
        key = f"n:{n}" if n != "spot_loop3" else n
        row = [f"{n:,}" if n != "spot_loop3" else "737,986 (spot_loop3)"]
        for st in STORAGES:
            b = sc.get(f"scaling/vertices/{st}/{key}")
            row += [
                fmt(b["ms_per_frame"]) if b else "n/a",
                fmt(b["fps"]) if b else "n/a",
                fmt(b["memory_bytes"] / 2**20) if b else "n/a",
                ("yes" if b["precomputed"] else "no") if b else "n/a",
            ]
        rows.append(row)
    ax.axhline(1000 / 60, color="grey", linestyle=":", label="60 fps")
    ax.set_xlabel("vertices")
    ax.set_ylabel("ms per frame")
    ax.set_title("time per frame vs vertex count (float, all cores)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(plots, "scaling_vertices.png"), dpi=110)
    plt.close(fig)
    md.append("### Vertices (10 handles)\n")
    md.append("![time per frame vs vertices](plots/scaling_vertices.png)\n")
    md.append(
        table(
            [
                "vertices",
            ]
            + [h for st in STORAGES for h in [f"{LABELS[st]} ms", "fps", "memory MiB", "precomputed?"]],
            rows,
        )
    )
    md.append("")

    ks = [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    rows = []
    for st in STORAGES:
        xs, ys = [], []
        for k in ks:
            ms = sc.get(f"scaling/handles/{st}/k:{k}", "ms_per_frame")
            if ms:
                xs.append(k), ys.append(ms)
        if xs:
            ax.loglog(xs, ys, marker="o", label=st)
    for k in ks:
        row = [k]
        for st in STORAGES:
            b = sc.get(f"scaling/handles/{st}/k:{k}")
            row += [
                fmt(b["ms_per_frame"]) if b else "n/a",
                fmt(b["ns_per_vertex_handle"]) if b else "n/a",
                fmt(b["memory_bytes"] / 2**20) if b else "n/a",
            ]
        rows.append(row)
    ax.set_xlabel("handles")
    ax.set_ylabel("ms per frame")
    ax.set_title("time per frame vs handle count (10^4 vertices, float, all cores)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(plots, "scaling_handles.png"), dpi=110)
    plt.close(fig)
    md.append("### Handles (10^4 vertices)\n")
    md.append("![time per frame vs handles](plots/scaling_handles.png)\n")
    md.append(
        table(
            [
                "handles",
            ]
            + [h for st in STORAGES for h in [f"{LABELS[st]} ms", "ns per vertex-handle", "memory MiB"]],
            rows,
        )
    )
    md.append("")
    rows = []
    for st in STORAGES:
        for n in [100000, 1000000]:
            names = sorted(sc.names(f"scaling/threads/{st}/n:{n}/threads:"), key=lambda s: int(s.split(":")[-1]))
            if not names:
                continue
            base = sc.get(names[0], "ms_per_frame")
            for nm in names:
                ms = sc.get(nm, "ms_per_frame")
                rows.append([st, f"{n:,}", nm.split(":")[-1], fmt(ms), fmt(ratio(base, ms)) + "x"])
    md.append("### Threads (10 handles)\n")
    md.append(table(["storage", "vertices", "threads", "ms per frame", "speed-up"], rows))
    md.append("")
    rows = []
    for n in [10000, 100000, 1000000]:
        mls = sc.get(f"scaling/centroids/mls/n:{n}", "ms_per_frame")
        rbf = sc.get(f"scaling/centroids/rbf/n:{n}", "ms_per_frame")
        if mls and rbf:
            rows.append([f"{n:,}", fmt(mls), fmt(rbf), fmt(ratio(rbf, mls)) + "x"])
    if rows:
        md.append("### Centroids: MLS against RBF (10 handles, precomputed, all cores)\n")
        md.append(
            "`Centroids::rbf` (the paper's Sec. 7-8) stores its centroid weights where MLS stores its own, so "
            "the per-frame kernels are the same; target: at most 1.5x the time of MLS centroids. Ratio = "
            "rbf / mls time.\n"
        )
        md.append(table(["vertices", "mls ms", "rbf ms", "rbf / mls"], rows))
        md.append("")
