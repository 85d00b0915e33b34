"""Shape quality (bench_quality's own markdown tables) and the benchmarks that failed their check."""
import os


from . import arap_convergence
from .common import table


def write(md, inputs):
    """Appends the section to md (a list of markdown lines)."""
    res, rot, t2, sc, rf = inputs.res, inputs.rot, inputs.t2, inputs.sc, inputs.rf
    quality = os.path.join(res, "bench_quality.md")
    if os.path.exists(quality):
        md.append("## Shape quality: MLS, MLS + ARAP, CGAL's ARAP\n")
        md.append(
            "`bench_quality`: per vertex, the RMS relative error of its one-ring edges after their best "
            "rotation (0 = locally rigid), median and 95th percentile; deformed / rest edge length, 1st "
            "and 99th percentile; triangles whose deformed normal points against their rest normal turned "
            "by the ring rotation of at least two of their corners (tests/support/quality.hpp). ms per "
            "frame: the median of one frame from the rest pose, set-up (weights, factorisations) not "
            "timed; CGAL's deformation runs on one thread.\n"
        )
        md.append(
            "The human bend, as `mlsdeform figures` draws it from the library (the same mesh and handles; "
            "E: the ARAP energy):\n"
        )
        md.append("![MLS, MLS + 2 and MLS + 10 ARAP iterations on the human bend](figures/arap.png)\n")
        with open(quality) as f:
            md.append(f.read())
    # bench_quality --arap: convergence, acceleration, warm starts (its own markdown, headings included)
    arap = os.path.join(res, "bench_quality_arap.md")
    if os.path.exists(arap):
        with open(arap) as f:
            text = f.read()
            text = text[text.find("## ARAP") :]  # from its heading: the machine is said above
            heading, _, rest = text.partition("\n")
            md.append(heading + "\n")
            md.extend(arap_convergence.plot(res, inputs.plots))
            md.append(rest.lstrip("\n"))
    # ----------------------------------------------------------------------------------------------------
    # Skipped
    # ----------------------------------------------------------------------------------------------------
    errs = [
        (p, n, e)
        for p, r in [("bench_rotation_fit", rot), ("bench_table2", t2), ("bench_scaling", sc), ("bench_roofline", rf)]
        for n, e in r.errors.items()
    ]
    md.append("## Skipped benchmarks (failed their check)\n")
    if errs:
        md.append(table(["program", "benchmark", "message"], [[p, f"`{n}`", e] for p, n, e in errs]))
    else:
        md.append("None: every benchmark passed its check.")
    md.append("")
