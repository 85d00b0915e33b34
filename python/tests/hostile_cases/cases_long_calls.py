"""F5: long calls are bounded or interruptible (KeyboardInterrupt, out untouched)."""
import signal
import subprocess
import sys
import time


from .common import BadError, CLEAR, CORRECT, Hang, add, words_in


def build(args):
    # ---- F5: long calls are bounded or interruptible (KeyboardInterrupt, out untouched) ----
    long_calls = {
        "arap_iterations=10**6": """
V, F = grid(30)
d = mlsdeform.Deformer(V, points=V[[0, 29, 870, 899]], faces=F, arap_iterations=10**6)
out = np.full_like(V, 7.0)
def call(): d.deform(points=V[[0, 29, 870, 899]] + 0.1, out=out)
""",
        "exact_integral exponent 3e4": """
V = np.random.default_rng(1).uniform(-1, 1, (2000, 3))
A = np.random.default_rng(2).uniform(-1, 1, (20, 3))
out = np.full_like(V, 7.0)
def call():
    d = mlsdeform.Deformer(V, segments=(A, A + 0.3), segment_weight="exact_integral", exponent=3e4)
    d.deform(out=out)
""",
        "exact_integral exponent 1e7": """
V = np.random.default_rng(1).uniform(-1, 1, (200, 3))
A = np.random.default_rng(2).uniform(-1, 1, (4, 3))
out = np.full_like(V, 7.0)
def call():
    d = mlsdeform.Deformer(V, segments=(A, A + 0.3), segment_weight="exact_integral", exponent=1e7)
    d.deform(out=out)
""",
        "deform 10^6 vertices x 3000 handles on the fly": """
g = np.random.default_rng(1)
V = g.uniform(-1, 1, (1000000, 3))
P = g.uniform(-1, 1, (3000, 3))
d = mlsdeform.Deformer(V, points=P, weight_storage="on_the_fly", threads=1)
out = np.full_like(V, 7.0)
def call(): d.deform(points=P + 0.1, out=out)
""",
        "fit_rotations 1.5 x 10^7 matrices by SVD": """
H = np.ones((15000000, 3, 3), np.float32)
out = np.full_like(H, 7.0)
def call(): mlsdeform.fit_rotations(H, out=out, threads=1, method="svd")
""",
    }
    for name, code in long_calls.items():

        def f(g, code=code):
            return interruptible(code)

        add("interrupt", name, f, timeout=240, quick=(name == "arap_iterations=10**6"))


def interruptible(code):
    """Runs code's call() in a child; SIGINT after 1 s: it must end within 5 s with KeyboardInterrupt and out
    untouched, or have ended before with a result or a clear refusal."""
    prelude = (
        "import sys, numpy as np, mlsdeform\n"
        "def grid(m):\n"
        "    x, y = np.meshgrid(np.linspace(0, 1, m), np.linspace(0, 1, m), indexing='ij')\n"
        "    V = np.stack([x.ravel(), y.ravel(), 0 * x.ravel()], 1)\n"
        "    F = [[i*m+j, (i+1)*m+j, (i+1)*m+j+1] for i in range(m-1) for j in range(m-1)]\n"
        "    F += [[i*m+j, (i+1)*m+j+1, i*m+j+1] for i in range(m-1) for j in range(m-1)]\n"
        "    return V, np.array(F)\n"
    )
    epilogue = (
        "\nprint('ready', flush=True)\n"
        "try:\n"
        "    call()\n"
        "    print('finished', flush=True)\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', 'untouched' if np.all(out == 7.0) else 'written', flush=True)\n"
        "except (ValueError, MemoryError) as e:\n"
        "    print('refused', type(e).__name__, e, flush=True)\n"
    )
    child = subprocess.Popen(
        [sys.executable, "-c", prelude + code + epilogue], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        line = child.stdout.readline()
        if not line.startswith("ready"):
            child.kill()
            raise BadError(f"the child did not start: {line!r} {child.stderr.read()[-300:]}")
        t0 = time.monotonic()
        time.sleep(1.0)
        if child.poll() is None:
            child.send_signal(signal.SIGINT)
        try:
            out, err = child.communicate(timeout=5)
        except subprocess.TimeoutExpired:
            child.kill()
            child.communicate()
            raise Hang(f"still running 5 s after SIGINT ({time.monotonic() - t0:.1f} s in the call)")
    finally:
        if child.poll() is None:
            child.kill()
    if child.returncode < 0 and -child.returncode != signal.SIGINT:
        raise BadError(f"child died by signal {-child.returncode}: {err[-300:]}")
    if out.startswith("interrupted untouched"):
        return CLEAR
    if out.startswith("interrupted written"):
        raise Hang("not interrupted: the call ran to its end and wrote out= before KeyboardInterrupt")
    if out.startswith("finished"):
        return CORRECT
    if out.startswith("refused"):
        if words_in(out, ["exponent", "iterations", "memory", "too", "limit", "at most"]):
            return CLEAR
        raise BadError(out.strip())
    raise BadError(f"child: {out.strip()!r} {err[-300:]!r}")
