"""F6 and F8: the program (only with --cli)."""
import json
import os
import subprocess
import tempfile

import numpy as np


from .common import BadError, CLEAR, CORRECT, EPS, EPS64, Skip, Wrong, add, within


def build(args):
    # ---- F6 and F8: the program (only with --cli) ----
    cli_cases = {
        "survey-grade OBJ in double": (
            "double",
            lambda g: 5e6 + g.uniform(0, 10, (40, 3)) * [1, 1, 0.1] + [0, -1e6, -5e6 + 100],
            "",
            "cli-double",
        ),
        "coordinates at 1e39 in double": ("double", lambda g: 1e39 * g.uniform(-1, 1, (40, 3)), "", "cli-double"),
        "coordinates at 1e-46 in double": ("double", lambda g: 1e-46 * g.uniform(-1, 1, (40, 3)), "", "cli-double"),
        "coordinates at 1e300 in double": ("double", lambda g: 1e300 * g.uniform(-1, 1, (40, 3)), "", "cli-double"),
        "coordinates at 1e39 in float": ("float", lambda g: 1e39 * g.uniform(-1, 1, (40, 3)), "", "cli-double"),
        "OBJ with a UTF-8 byte-order mark": ("float", lambda g: g.uniform(-1, 1, (40, 3)), "\ufeff", "cli-bom"),
        "plain OBJ in float": ("float", lambda g: g.uniform(-1, 1, (40, 3)), "", "cli"),
    }
    for name, (precision, make, prefix, tag) in cli_cases.items():

        def f(g, precision=precision, make=make, prefix=prefix):
            return cli_identity(args.cli, precision, make(g), prefix)

        add(tag, name, f, timeout=60)


def cli_identity(program, precision, V, prefix):
    """The program with handles on vertices that move nothing: every vertex must come back as it was (to the
    precision's rounding), or the file be refused with exit code 2 and a line naming it."""
    if not program:
        raise Skip("no program (--cli or MLSDEFORM_CLI)")
    n = len(V)
    with tempfile.TemporaryDirectory() as tmp:
        mesh, handles, out = (os.path.join(tmp, x) for x in ("in.obj", "h.json", "out.obj"))
        with open(mesh, "w", encoding="utf-8") as fh:
            fh.write(prefix)
            for v in V:
                fh.write("v %s %s %s\n" % tuple(repr(float(x)) for x in v))
            fh.write("f 1 2 3\n")
        with open(handles, "w") as fh:
            json.dump({"points": [{"vertex": i} for i in (0, n // 3, 2 * n // 3, n - 1)]}, fh)
        r = subprocess.run(
            [program, "deform", "-m", mesh, "-H", handles, "-o", out, "--precision", precision, "--quiet"],
            capture_output=True,
            text=True,
            timeout=50,
        )
        if r.returncode == 2:
            line = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else ""
            fits = precision == "double" or np.abs(V).max() < np.finfo(np.float32).max / 64
            if not fits and "in.obj" in line:
                return CLEAR
            raise BadError(f"exit 2 for input the {precision} precision holds: {line}")
        if r.returncode != 0:
            raise BadError(f"exit {r.returncode}: {r.stderr[-300:]}")
        got = []
        with open(out) as fh:
            for line in fh:
                if line.startswith("v "):
                    got.append([float(x) for x in line.split()[1:4]])
    got = np.array(got)
    eps = EPS64 if precision == "double" else EPS[np.float32]
    if precision == "float" and np.abs(V).max() >= np.finfo(np.float32).max / 64:
        raise Wrong("coordinates beyond float's range were taken in float precision")
    # Nothing moves: MLS gives q* + R (v - p*) with R = I to a few eps, so each coordinate comes back within
    # 64 eps of the model's largest coordinate (input rounding to the precision included).
    within(got, V, 64 * eps * np.abs(V).max() * np.sqrt(3), "vertices that nothing moved")
    return CORRECT
