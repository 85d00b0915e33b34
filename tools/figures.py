#!/usr/bin/env python3
"""Draws a figure described by a JSON spec that `mlsdeform figures` / `mlsdeform demo` write.

    python3 tools/figures.py SPEC.json     # writes the PNG named by the spec's "output"
    python3 tools/figures.py --check       # exit 0 if matplotlib is usable here

The spec: {"title", "caption", "rows", "cols", "panel_size": [w, h] inches, "dpi", "shared_bounds", "output",
"panels": [{"title", "view": {"elev", "azim"}, "row_span", "meshes": [{"vertices": flat xyz, "triangles": flat ijk,
"color", "alpha", optional "triangle_colors"}], "points": [{"xyz", "color", "size", "marker", "label"}],
"segments": [{"a", "b", "color", "width", "arrow", "label"}], optional "plot": {"xlabel", "ylabel", "log_x",
"series": [{"label", "color", "x", "y"}]}}]}: a panel with "plot" is a 2D chart; panels fill the grid's free
cells row by row, each "row_span" rows tall. Models are y-up; matplotlib's 3D axes are z-up, so (x, y, z) is
drawn at (x, -z, y).

Meshes are shaded per triangle (two-sided Lambert with a headlight-like key light), drawn with an
orthographic camera; handles are drawn on top of the mesh so they are never hidden.
"""
import json
import os
import sys


def check():
    import matplotlib  # noqa: F401

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
    from mpl_toolkits.mplot3d import Axes3D  # noqa: F401

    return 0


def to_plot(a):
    """Model coordinates (y up) -> matplotlib's (z up): a proper rotation, so handedness is kept."""
    import numpy as np

    a = np.asarray(a, dtype=float).reshape(-1, 3)
    return np.stack([a[:, 0], -a[:, 2], a[:, 1]], axis=1)


def light_direction(elev, azim):
    """A key light from the camera's upper left, in plot coordinates."""
    import numpy as np

    e, z = np.radians(elev + 25.0), np.radians(azim - 35.0)
    return np.array([np.cos(e) * np.cos(z), np.cos(e) * np.sin(z), np.sin(e)])


def draw(spec):
    import numpy as np
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection, Line3DCollection

    import textwrap

    rows, cols = spec["rows"], spec["cols"]
    pw, ph = spec["panel_size"]
    title = textwrap.wrap(spec.get("title", ""), width=int(pw * cols * 9))  # ~9 characters per inch at 12 pt
    title_height = 0.15 + 0.25 * len(title) if title else 0.0  # inches
    fig = plt.figure(
        figsize=(pw * cols, ph * rows + title_height + (0.35 if spec.get("caption") else 0)), dpi=spec.get("dpi", 110)
    )

    # The union of all panels' extents, so that before and after share one scale.
    def extent(panel):
        pts = [to_plot(m["vertices"]) for m in panel["meshes"] if m["vertices"]]
        pts += [to_plot(p["xyz"]) for p in panel["points"] if p["xyz"]]
        pts += [to_plot(s["a"]) for s in panel["segments"] if s["a"]] + [
            to_plot(s["b"]) for s in panel["segments"] if s["b"]
        ]
        if not pts:
            return None
        p = np.concatenate(pts)
        return p.min(axis=0), p.max(axis=0)

    extents = [extent(p) for p in spec["panels"]]
    if spec.get("shared_bounds", True) and any(e is not None for e in extents):
        lo = np.min([e[0] for e in extents if e is not None], axis=0)
        hi = np.max([e[1] for e in extents if e is not None], axis=0)
        extents = [(lo, hi)] * len(extents)

    # Each panel's cell: the first free one, row by row; a panel "row_span" rows tall takes the cells below too.
    grid = fig.add_gridspec(rows, cols)
    taken = set()
    cells = []
    for panel in spec["panels"]:
        r, c = next((r, c) for r in range(rows) for c in range(cols) if (r, c) not in taken)
        span = max(1, min(panel.get("row_span", 1), rows - r))
        taken.update((r + k, c) for k in range(span))
        cells.append(grid[r : r + span, c])

    legend = {}
    charts = []
    for i, panel in enumerate(spec["panels"]):
        if panel.get("plot"):
            plot = panel["plot"]
            ax = fig.add_subplot(cells[i])
            for sr in plot["series"]:
                ax.plot(sr["x"], sr["y"], color=sr.get("color", [0.1, 0.3, 0.9]), lw=1.6, label=sr.get("label"))
            if plot.get("log_x"):
                ax.set_xscale("log")
            ax.set_xlabel(plot.get("xlabel", ""), fontsize=9)
            ax.set_ylabel(plot.get("ylabel", ""), fontsize=9)
            ax.tick_params(labelsize=8)
            ax.grid(True, which="both", lw=0.3, color="0.85")
            ax.legend(fontsize=8, frameon=False, loc="upper left")
            ax.set_title(panel.get("title", ""), fontsize=10)
            charts.append(ax)
            continue
        ax = fig.add_subplot(cells[i], projection="3d")
        ax.computed_zorder = False  # our order: meshes first, then handles on top
        view = panel.get("view", {})
        elev, azim = view.get("elev", 12), view.get("azim", -65)
        ax.view_init(elev=elev, azim=azim)
        ax.set_proj_type("ortho")
        ax.set_axis_off()
        ax.set_title(panel.get("title", ""), fontsize=10, pad=0)
        light = light_direction(elev, azim)

        for m in panel["meshes"]:
            v = to_plot(m["vertices"])
            t = np.asarray(m["triangles"], dtype=np.int64).reshape(-1, 3)
            if len(t) == 0:
                continue
            tri = v[t]
            n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            length = np.linalg.norm(n, axis=1)
            n = n / np.where(length > 0, length, 1.0)[:, None]
            shade = 0.35 + 0.65 * np.abs(n @ light)
            base = np.asarray(m.get("triangle_colors") or m.get("color", [0.78, 0.8, 0.86]), dtype=float).reshape(-1, 3)
            colors = np.clip(shade[:, None] * base, 0, 1)
            alpha = m.get("alpha", 1.0)
            colors = np.concatenate([colors, np.full((len(colors), 1), alpha)], axis=1)
            pc = Poly3DCollection(tri, facecolors=colors, edgecolors="none", linewidths=0, zorder=1)
            ax.add_collection3d(pc)

        for s in panel["segments"]:
            a, b = to_plot(s["a"]), to_plot(s["b"])
            if len(a) == 0:
                continue
            c = s.get("color", [0.1, 0.3, 0.9])
            if s.get("arrow"):
                d = b - a
                h = ax.quiver(
                    a[:, 0],
                    a[:, 1],
                    a[:, 2],
                    d[:, 0],
                    d[:, 1],
                    d[:, 2],
                    color=c,
                    linewidths=s.get("width", 1.0),
                    arrow_length_ratio=0.15,
                    zorder=3,
                    normalize=False,
                )
            else:
                h = Line3DCollection(np.stack([a, b], axis=1), colors=[c], linewidths=s.get("width", 2.5), zorder=4)
                ax.add_collection3d(h)
            if s.get("label") and s["label"] not in legend:
                legend[s["label"]] = plt.Line2D(
                    [], [], color=c, lw=max(1.5, s.get("width", 2.5)), marker=">" if s.get("arrow") else None
                )

        for p in panel["points"]:
            x = to_plot(p["xyz"])
            if len(x) == 0:
                continue
            c = p.get("color", [0.1, 0.3, 0.9])
            ax.scatter(
                x[:, 0],
                x[:, 1],
                x[:, 2],
                s=p.get("size", 18),
                c=[c],
                marker=p.get("marker", "o"),
                depthshade=False,
                edgecolors="white" if p.get("size", 18) >= 12 else "none",
                linewidths=0.4,
                zorder=5,
            )
            if p.get("label") and p["label"] not in legend:
                legend[p["label"]] = plt.Line2D([], [], color=c, lw=0, marker=p.get("marker", "o"), markersize=6)

        e = extents[i]
        if e is not None:
            lo, hi = e
            centre, half = (lo + hi) / 2, (hi - lo) / 2 * 1.04 + 1e-9
            ax.set_xlim(centre[0] - half[0], centre[0] + half[0])
            ax.set_ylim(centre[1] - half[1], centre[1] + half[1])
            ax.set_zlim(centre[2] - half[2], centre[2] + half[2])
            ax.set_box_aspect(tuple(2 * half))

    top = 1.0
    if title:
        fig.suptitle("\n".join(title), fontsize=12, y=1.0 - 0.08 / fig.get_figheight(), va="top")
        top = 1.0 - title_height / fig.get_figheight()
    bottom = 0.0
    if legend:
        fig.legend(
            legend.values(),
            legend.keys(),
            loc="lower center",
            ncol=min(len(legend), 5),
            fontsize=8,
            frameon=False,
            bbox_to_anchor=(0.5, 0.35 / fig.get_figheight() if spec.get("caption") else 0.0),
        )
        bottom = 0.3 / fig.get_figheight()
    if spec.get("caption"):
        fig.text(0.5, 0.01, spec["caption"], ha="center", va="bottom", fontsize=8, wrap=True, color="0.25")
        bottom += 0.35 / fig.get_figheight()
    fig.subplots_adjust(left=0, right=1, bottom=bottom, top=top, wspace=0, hspace=0.02)
    for ax in charts:  # room for the tick labels and axis titles inside the chart's cell
        p = ax.get_position()
        ax.set_position([p.x0 + 0.24 * p.width, p.y0 + 0.22 * p.height, 0.7 * p.width, 0.6 * p.height])

    out = spec["output"]
    tmp = os.path.join(os.path.dirname(out) or ".", "." + os.path.basename(out) + ".tmp.png")
    try:
        fig.savefig(tmp, dpi=spec.get("dpi", 110))
        os.replace(tmp, out)  # all or nothing
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    plt.close(fig)


def main(argv):
    if len(argv) == 2 and argv[1] == "--check":
        return check()
    if len(argv) != 2 or argv[1].startswith("-"):
        print(__doc__, file=sys.stderr)
        return 2
    with open(argv[1]) as f:
        spec = json.load(f)
    draw(spec)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
