"""What the sections share: the results of one benchmark program, number formats and markdown tables."""
import json
import os


# The paper's Table 2 models: name -> (vertices, handles, source).
MODELS = {
    "Dolphin": (
        2811,
        4,
        '`fish.obj` ("Blub", Keenan Crane, remeshed by O. Stein; public domain), random 2,811 of 10,786 vertices',
    ),
    "Homer": (
        5103,
        6,
        '`human_man.obj` (SMPL template mesh, Max Planck Society, CC BY 4.0; Loper et al., "SMPL", '
        "SIGGRAPH Asia 2015), random 5,103 of 6,890 vertices",
    ),
    "Plane": (1089, 132, "generated 33 x 33 grid"),
    "Dino": (
        14050,
        5,
        '`spot_loop3.ply.gz` ("Spot", Keenan Crane, remeshed by O. Stein, 3 Loop subdivisions; public '
        "domain), random 14,050 of 737,986 vertices",
    ),
    "Bar": (6146, 256, "generated 16 x 16 x 88 box surface"),
    "Cylinder": (1058, 322, "generated open cylinder, 46 x 23"),
}
METHODS = ["axis_angle", "horn_quaternion", "horn_matrix", "kanatani", "svd", "qcp"]
METHOD_NOTES = {
    "axis_angle": "the paper's method (Sec. 4), library",
    "horn_quaternion": "Horn 1987, library (Eigen 4x4 eigensolver; batched: Jacobi in lanes)",
    "horn_matrix": "Horn et al. 1988, library",
    "kanatani": "Kanatani 1994, library (Eigen JacobiSVD)",
    "svd": "Arun/Umeyama, library (Eigen JacobiSVD)",
    "qcp": "QCP (Theobald 2005; Liu et al. 2010), `bench/qcp.hpp`",
    "paper_eq14_literal": "the paper's (14)-(15) as written (`bench/paper_literal.hpp`, not a library method)",
}


def load(path):
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


class Results:
    """The benchmarks of one program, by name without the '/real_time' suffix; medians where repeated."""

    def __init__(self, data):
        self.context = data["context"] if data else {}
        self.by_name = {}
        self.errors = {}
        if not data:
            return
        runs = {}
        for b in data["benchmarks"]:
            name = b.get("run_name", b["name"]).replace("/real_time", "")
            if b.get("error_occurred"):
                self.errors[name] = b.get("error_message", "error")
                continue
            if b.get("run_type") == "aggregate":
                if b.get("aggregate_name") == "median":
                    runs[name] = b
            elif name not in runs:
                runs[name] = b
        self.by_name = runs

    def get(self, name, key=None):
        b = self.by_name.get(name)
        if b is None:
            return None
        return b if key is None else b.get(key)

    def names(self, prefix):
        return [n for n in self.by_name if n.startswith(prefix)]


def fmt(x, digits=3):
    if x is None:
        return "n/a"
    if x == 0:
        return "0"
    if abs(x) >= 1000:
        return f"{x:,.0f}"
    return f"{x:.{digits}g}"


def count(x):
    """A count from a context string, with thousands separators."""
    try:
        return f"{int(x):,}"
    except (TypeError, ValueError):
        return "?"


def ratio(a, b):
    if a is None or b is None or b == 0:
        return None
    return a / b


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def status(ok):
    return "**met**" if ok else "**not met**"
