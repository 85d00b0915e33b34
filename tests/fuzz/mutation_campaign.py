#!/usr/bin/env python3
"""Mutation campaign for the mesh readers of the `mlsdeform` program, run as a user runs it.

Generates a small valid mesh in every readable format (OBJ, OFF, PLY ASCII, PLY binary little- and big-endian,
and the .gz of each; the splat formats SPZ, .splat and compressed PLY from tests/fuzz/corpus_*), mutates each
file N times (bytes, tokens, header counts, gzip members; a few gzip bombs), runs `mlsdeform deform` on every
mutant with a fresh output folder, and checks the program's contract:

  exit 0  the mesh was read: the output file exists, nothing else is left in the folder
  exit 2  bad input: exactly one line on stderr, "mlsdeform: error: <the mesh's path>: ...", no file left (or
          <the handles file's path>: a mutated mesh can have fewer vertices than the handles name)
  other   a bug (exit 1, a signal, a sanitizer report, a timeout)

Prints a table per format (mutants, exits, bugs, peak RSS, time) and saves every bug's input and stderr under
OUT_DIR/bugs/. Exit status 1 if any bug. Deterministic for a given --seed. --precision double runs the program's
double readers and writers (its PLY seeds then have double properties).

  python3 tests/fuzz/mutation_campaign.py --program build/tools/mlsdeform --out-dir /tmp/mutation --per-format 1000
"""
import argparse
import concurrent.futures
import json
import os
import random
import resource
import shutil
import subprocess
import sys
import threading
import time
import zlib

from mutations import SPLAT_KINDS, encode, make_mutant, make_splat_mutant, seed_mesh, splat_seeds  # beside this


# GNU time (Debian's `time` package) measures the program's own peak RSS. Without it, the child's rusage is
# used, which also counts this script's pages that the child shares between fork and exec (printed as a floor).
TIME = shutil.which("time", path="/usr/bin:/bin")


def run_one(program, path, out_dir, timeout, extra, handles_name="handles.json"):
    """Runs the program on one mesh; (exit code, bug or None, peak RSS MiB, seconds, stderr)."""
    os.makedirs(out_dir)
    out = os.path.join(out_dir, "out.ply")
    err_path = path + ".stderr"
    handles = os.path.join(os.path.dirname(out_dir), handles_name)
    with open(err_path, "wb") as err:
        start = time.monotonic()
        command = [program, "deform", "-m", path, "-H", handles, "-o", out, "-q"] + extra
        rss_file = path + ".rss"
        if TIME:  # GNU time forks the program from a small process: its peak RSS is the program's own
            command = [TIME, "-f", "%M", "-o", rss_file] + command
        # Its own session, so that a timeout kills the program and not only GNU time above it.
        proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=err, start_new_session=True)
        timed_out = threading.Event()

        def kill():
            timed_out.set()
            try:
                os.killpg(proc.pid, 9)
            except ProcessLookupError:
                pass

        timer = threading.Timer(timeout, kill)
        timer.start()
        _, status, usage = os.wait4(proc.pid, 0)  # Popen.wait would not give the child's rusage
        timer.cancel()
        proc.returncode = os.waitstatus_to_exitcode(status)
        elapsed = time.monotonic() - start
    stderr = open(err_path, "rb").read().decode(errors="replace")
    rss = usage.ru_maxrss / 1024.0
    if TIME:
        with open(rss_file) as f:
            last = f.read().split()
        rss = int(last[-1]) / 1024.0 if last and last[-1].isdigit() else float("nan")
        os.remove(rss_file)
    left = sorted(os.listdir(out_dir))
    code = proc.returncode
    if timed_out.is_set():
        bug = "timeout after %g s" % timeout
    elif code == 0:
        bug = None if left == ["out.ply"] else "exit 0 but the output folder holds %s" % left
    elif code == 2:
        lines = stderr.split("\n")
        bug = None
        if len(lines) != 2 or lines[1]:
            bug = "exit 2 with %d lines on stderr" % (len(lines) - 1)
        elif any(ord(c) < 32 or ord(c) == 127 for c in lines[0]):
            bug = "exit 2, control characters in the message"
        elif not any(lines[0].startswith("mlsdeform: error: %s: " % f) for f in (path, handles)):
            bug = "exit 2, message names neither the mesh nor the handles file"  # a mutated mesh may not fit them
        elif left:
            bug = "exit 2 but files left: %s" % left
    else:
        bug = "exit %d" % code
    shutil.rmtree(out_dir)
    return code, bug, rss, elapsed, stderr


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--program", required=True)
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--per-format", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=20)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument(
        "--precision",
        choices=["float", "double"],
        default="float",
        help="passed to the program; with double, the PLY seeds have double properties",
    )
    args = ap.parse_args()
    print("command:", " ".join([sys.executable] + sys.argv), flush=True)
    shutil.rmtree(args.out_dir, ignore_errors=True)
    os.makedirs(os.path.join(args.out_dir, "bugs"))
    verts, faces = seed_mesh()
    kinds = ["obj", "off", "ply", "le.ply", "be.ply"]
    base = {k: encode(verts, faces, k, args.precision) for k in kinds}
    kinds += [k + ".gz" for k in ("obj", "off", "ply", "le.ply")]
    splats = splat_seeds(os.path.dirname(os.path.abspath(__file__)))
    kinds += list(SPLAT_KINDS)
    # Two handles at different positions: vertex 0 fixed, the last one moved.
    with open(os.path.join(args.out_dir, "handles.json"), "w") as f:
        json.dump({"points": [{"vertex": 0}, {"vertex": len(verts) - 1, "offset": [0, 0.1, 0]}]}, f)
    # The splat seeds have a few splats: handles placed by rest position, one fixed, one moved.
    with open(os.path.join(args.out_dir, "handles_rest.json"), "w") as f:
        json.dump({"points": [{"rest": [0, 0, 0]}, {"rest": [1, 1, 1], "offset": [0, 0.1, 0]}]}, f)
    # Mutants are made in the workers, one at a time: a child's peak RSS counts what it shares with this
    # process between fork and exec, so this process stays small (its own peak is printed as the floor).
    jobs = [(kind, i, None) for kind in kinds for i in range(args.per_format)]
    # Gzip bombs: 200 MB of valid-looking lines, compressed to a few hundred KB, read with a 64 MiB limit.
    z = zlib.compressobj(9, zlib.DEFLATED, 31)  # 31: a gzip member
    line = b"v 0 0 0\n" * (1 << 17)
    bomb = b"".join(z.compress(line) for _ in range(200)) + z.flush()
    for i, kind in enumerate(["obj.gz", "off.gz", "ply.gz"]):
        jobs.append((kind, args.per_format + i, bomb))
    stats = {k: {"n": 0, "0": 0, "2": 0, "bugs": 0, "rss": 0.0, "time": 0.0} for k in kinds}

    def work(job):
        kind, i, data = job
        extra = ["--precision", args.precision]
        rng = random.Random("%d/%s/%d" % (args.seed, kind, i))
        if data is None:
            data = make_splat_mutant(kind, splats, rng) if kind in SPLAT_KINDS else make_mutant(kind, base, rng)
        else:
            extra += ["--max-input-mib", "64"]
        path = os.path.join(args.out_dir, "m%05d.%s" % (i, kind))
        with open(path, "wb") as f:
            f.write(data)
        del data
        handles = "handles_rest.json" if kind in SPLAT_KINDS else "handles.json"
        out_dir = os.path.join(args.out_dir, "o_%s_%d" % (kind, i))
        result = run_one(args.program, path, out_dir, args.timeout, extra, handles)
        return kind, path, result

    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        for kind, path, (code, bug, rss, elapsed, stderr) in pool.map(work, jobs):
            s = stats[kind]
            s["n"] += 1
            s[str(code)] = s.get(str(code), 0) + 1
            s["rss"], s["time"] = max(s["rss"], rss), max(s["time"], elapsed)
            if bug:
                s["bugs"] += 1
                shutil.copy(path, os.path.join(args.out_dir, "bugs"))
                with open(os.path.join(args.out_dir, "bugs", os.path.basename(path) + ".txt"), "w") as f:
                    f.write("%s\n%s" % (bug, stderr))
                print("BUG %s: %s: %s" % (os.path.basename(path), bug, stderr.strip()[:300]), flush=True)
            os.remove(path)
            os.remove(path + ".stderr")
    print(
        "%-9s %8s %8s %8s %6s %14s %12s"
        % ("format", "mutants", "exit 0", "exit 2", "bugs", "peak RSS MiB", "max time s")
    )
    for kind in kinds:
        s = stats[kind]
        print("%-9s %8d %8d %8d %6d %14.1f %12.2f" % (kind, s["n"], s["0"], s["2"], s["bugs"], s["rss"], s["time"]))
    if not TIME:
        print(
            "(no /usr/bin/time: peak RSS includes this script's own %.1f MiB, shared until the child execs)"
            % (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)
        )
    total_bugs = sum(s["bugs"] for s in stats.values())
    print("bugs: %d" % total_bugs)
    return 1 if total_bugs else 0


if __name__ == "__main__":
    sys.exit(main())
