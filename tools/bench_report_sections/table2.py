"""The paper's Table 2: frames per second on its models."""


from .common import MODELS, fmt, ratio, table


def write(md, inputs):
    """Appends the section to md (a list of markdown lines)."""
    t2, ctx = inputs.t2, inputs.ctx
    md.append("## The paper's Table 2: frames per second\n")
    md.append(
        "`bench/bench_table2.cpp`: rigid MLS, float, weight exponent 2, handles at random vertices twisted "
        "by up to 90 degrees about the long axis plus a bend. `naive`: per-vertex loop with "
        "`Eigen::JacobiSVD` written from the paper (`bench/naive_mls.hpp`), 1 core; `scalar`: `Deformer` "
        "with `Options::isa = Isa::scalar`, 1 thread; `simd 1t` / `simd all`: `Options::isa` unset, 1 thread / all "
        f"{ctx.get('hardware_threads', '?')} threads. The paper's figures are from a Pentium 4 at 3.2 GHz "
        "(2009) and include OpenGL rendering. Single-thread variants are timed by the thread's CPU time, "
        "`simd all` by wall-clock time (see Timing below).\n"
    )
    rows = []
    for model, (nv, nh, src) in MODELS.items():
        g = lambda v, k="fps": t2.get(f"table2/{model}/{v}", k)  # noqa: E731
        naive, scal, s1, sa, paper = g("naive"), g("scalar"), g("simd_1t"), g("simd_all"), g("naive", "paper_fps")
        if paper is None:
            paper = g("simd_all", "paper_fps")
        pre = g("simd_all", "precomputed")
        mem = g("simd_all", "memory_bytes")
        rows.append(
            [
                model,
                f"{nv:,}",
                nh,
                fmt(paper),
                fmt(naive),
                fmt(scal),
                fmt(s1),
                fmt(sa),
                fmt(ratio(s1, naive)),
                fmt(ratio(sa, naive)),
                fmt(ratio(s1, scal)),
                fmt(ratio(sa, scal)),
                fmt(ratio(sa, paper)),
                ("precomputed" if pre else "on the fly") if pre is not None else "n/a",
                fmt(mem / 2**20 if mem else None) + " MiB" if mem else "n/a",
            ]
        )
    md.append(
        table(
            [
                "model",
                "vertices",
                "handles",
                "paper fps",
                "naive fps",
                "scalar fps",
                "simd 1t fps",
                "simd all fps",
                "simd 1t / naive",
                "simd all / naive",
                "simd 1t / scalar",
                "simd all / scalar",
                "simd all / paper",
                "weights",
                "precomputation",
            ],
            rows,
        )
    )
    md.append("\nModels (vertex positions only; MLS never reads the faces):\n")
    for model, (nv, nh, src) in MODELS.items():
        md.append(f"- {model}: {src}.")
    md.append(
        "\nThe shared meshes come from github.com/odedstein/meshes; licences and attribution in "
        "`../shared/data/meshes/LICENSES.txt`.\n"
    )
