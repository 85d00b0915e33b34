#!/usr/bin/env python3
"""A hostile campaign against the Python package (and, given the program, a few of its file cases): about
1,800 cases, each run in a worker process and classified by its outcome:

  correct       the result holds against an independent numpy reference or an exact invariant
  clear error   a refusal of the expected type whose message names the argument or the reason
  SILENT WRONG  a result that does not hold (wrong values, NaN, an input taken that must be refused, out=
                written by a refused call)
  BAD ERROR     an exception where a result was due, of the wrong type, or whose message names nothing
  CRASH         the worker process died (a segfault, an abort)
  HANG          no answer within the case's time limit, or no KeyboardInterrupt within 5 s of SIGINT

    PYTHONPATH=build/python /usr/bin/python3 python/tests/hostile_campaign.py [--seed N] [--quick]
        [--cli build/tools/mlsdeform] [--only TAG,...] [--list] [--verbose] [--json FILE]

Prints the counts by outcome and by tag and every failing case with its detail, and exits 1 if any case is a
SILENT WRONG, BAD ERROR, CRASH or HANG (0 otherwise). A worker runs the cases one after the other and reports
each before the next starts, so a crash or a hang is charged to its own case and the campaign goes on in a
fresh worker. The program's cases (tags starting with cli) need --cli or MLSDEFORM_CLI and are skipped without. --quick
leaves out the slow long-call cases but one (python/tests/test_hostile_campaign.py runs it).

Tolerances are derived where they are used, from the precision and the conditioning of the problem; every
comparison is against numpy in float64 (SVD for rotation fits, a direct per-vertex MLS straight from the
paper's equations, an RBF solve) or against an exact invariant (rest pose, rigid motions, bitwise equality
between paths that must agree, scale by powers of two).

The cases are in hostile_cases/, one module per area (cases_<area>.py), with the checks, references and
scenes they share. The frames' oracle (motions.py) is an exact rigid, similarity or affine motion of every
handle: every vertex must get that motion's position and frame (cases_frames: every weight storage, on, near
and far from point and segment handles, outliers; cases_attributes: the program's normals; cases_dask).
"""
import argparse
import json
import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback

import numpy as np

from hostile_cases.common import (
    BAD_ERROR,
    CASES,
    CLEAR,
    CORRECT,
    CRASH,
    FAILURES,
    HANG,
    SILENT_WRONG,
    SKIPPED,
    BadError,
    Hang,
    Skip,
    Wrong,
    words_in,
)


# ---- the cases ---------------------------------------------------------------------------------------------


def build_cases(args):
    """Every case, registered in a fixed order (a case's id is its place in it, also in the worker)."""
    # Imported here, as mlsdeform itself: --help needs neither.
    from hostile_cases import (
        cases_arap,
        cases_attributes,
        cases_attributes_splats,
        cases_cli,
        cases_dask,
        cases_files_api,
        cases_fit_points,
        cases_fit_rotations,
        cases_frames,
        cases_groups,
        cases_helpers,
        cases_inputs,
        cases_long_calls,
        cases_mls,
        cases_objects,
        cases_rbf_region,
        cases_scale,
        cases_snap,
        cases_splats,
    )

    cases_fit_rotations.build(args)
    cases_fit_points.build(args)
    cases_mls.build(args)
    cases_inputs.build(args)
    cases_scale.build(args)
    cases_arap.build(args)
    cases_rbf_region.build(args)
    cases_groups.build(args)
    cases_mls.build_segments(args)
    cases_objects.build(args)
    cases_snap.build(args)
    cases_long_calls.build(args)
    cases_cli.build(args)
    cases_frames.build(args)
    cases_frames.build_isa(args)
    cases_frames.build_alias(args)
    cases_helpers.build(args)
    cases_splats.build(args)
    cases_attributes.build(args)
    cases_attributes_splats.build(args)
    cases_attributes.build_cube(args)
    cases_files_api.build(args)
    cases_dask.build(args)
    return CASES


# ---- driver ------------------------------------------------------------------------------------------------


def worker(args):
    cases = build_cases(args)
    for line in sys.stdin:
        ident = int(line)
        c = cases[ident]
        print(json.dumps({"start": ident}), flush=True)
        g = np.random.default_rng([args.seed, ident])
        t0 = time.monotonic()
        try:
            r = c.fn(g)
            outcome, detail = (CLEAR if r == CLEAR else CORRECT), ""
        except Wrong as e:
            outcome, detail = SILENT_WRONG, str(e)
        except BadError as e:
            outcome, detail = BAD_ERROR, str(e)
        except Hang as e:
            outcome, detail = HANG, str(e)
        except Skip as e:
            outcome, detail = SKIPPED, str(e)
        except Exception as e:  # noqa: BLE001 - classified here
            if c.accept and isinstance(e, c.accept[0]) and words_in(str(e), c.accept[1]):
                outcome, detail = CLEAR, f"{type(e).__name__}: {e}"
            else:
                outcome, detail = (
                    BAD_ERROR,
                    f"unexpected {type(e).__name__}: {e} | " + traceback.format_exc(limit=3).strip().splitlines()[-3],
                )
        print(
            json.dumps(
                {"id": ident, "outcome": outcome, "detail": detail[:400], "seconds": round(time.monotonic() - t0, 3)}
            ),
            flush=True,
        )


def run_all(args, ids, cases):
    """Feeds the ids to a worker, restarting it after a crash or a hang; returns {id: (outcome, detail)}."""
    results = {}
    pending = list(ids)
    while pending:
        cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--seed", str(args.seed)]
        if args.cli:
            cmd += ["--cli", args.cli]
        with tempfile.TemporaryFile("w+") as err:
            proc = subprocess.Popen(
                cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, text=True, start_new_session=True
            )
            lines = queue.Queue()
            threading.Thread(
                target=lambda: [lines.put(x) for x in proc.stdout] + [lines.put(None)], daemon=True
            ).start()
            proc.stdin.write("".join(f"{i}\n" for i in pending))
            proc.stdin.close()
            running, started = None, time.monotonic()
            while pending:
                limit = cases[running].timeout if running is not None else 120
                try:
                    line = lines.get(timeout=max(0.1, started + limit - time.monotonic()))
                except queue.Empty:
                    os.killpg(proc.pid, signal.SIGKILL)
                    ident = running if running is not None else pending[0]
                    results[ident] = (HANG, f"no answer within {limit} s")
                    pending.remove(ident)
                    break
                if line is None:
                    proc.wait()
                    err.seek(0)
                    tail = err.read()[-300:].strip().replace("\n", " | ")
                    ident = running if running is not None else pending[0]
                    results[ident] = (CRASH, f"worker exit {proc.returncode}: {tail}")
                    pending.remove(ident)
                    break
                msg = json.loads(line)
                if "start" in msg:
                    running, started = msg["start"], time.monotonic()
                    continue
                results[msg["id"]] = (msg["outcome"], msg["detail"])
                pending.remove(msg["id"])
                running = None
                if args.verbose:
                    c = cases[msg["id"]]
                    print(
                        f"{msg['outcome']:>12}  {msg['seconds']:7.2f}s  [{c.tag}] {c.name}"
                        + (f": {msg['detail']}" if msg["detail"] else ""),
                        flush=True,
                    )
            if proc.poll() is None:
                proc.wait(timeout=30)
    return results


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=20261124)
    ap.add_argument("--quick", action="store_true", help="leave out the slow cases (the pytest wrapper's run)")
    ap.add_argument("--only", default="", help="comma-separated tags (prefixes) to run")
    ap.add_argument("--cli", default=os.environ.get("MLSDEFORM_CLI", ""), help="the mlsdeform program")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--verbose", "-v", action="store_true")
    ap.add_argument("--json", default="", help="write every case's outcome to this file")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        return worker(args)
    cases = build_cases(args)
    chosen = [
        c
        for c in cases
        if (not args.only or any(c.tag.startswith(t) for t in args.only.split(","))) and (not args.quick or c.quick)
    ]
    if args.list:
        for c in chosen:
            print(f"{c.id:4d} [{c.tag}] {c.name}")
        return 0
    import mlsdeform

    t0 = time.monotonic()
    results = run_all(args, [c.id for c in chosen], cases)
    print(
        f"mlsdeform {mlsdeform.__version__} from {os.path.dirname(mlsdeform.__file__)}, ISA "
        f"{mlsdeform.active_isa()}, seed {args.seed}, {len(chosen)} cases in {time.monotonic() - t0:.0f} s"
    )
    order = (CORRECT, CLEAR, SKIPPED) + FAILURES
    print("outcomes: " + ", ".join(f"{o} {sum(r[0] == o for r in results.values())}" for o in order))
    tags = sorted({c.tag for c in chosen})
    print(f"\n{'tag':<26}" + "".join(f"{o:>14}" for o in order))
    for t in tags:
        row = [results[c.id][0] for c in chosen if c.tag == t]
        print(f"{t:<26}" + "".join(f"{row.count(o):>14}" for o in order))
    failed = [c for c in chosen if results[c.id][0] in FAILURES]
    if failed:
        print("\nfailing cases:")
        for c in failed:
            print(f"  {results[c.id][0]:>12}  #{c.id} [{c.tag}] {c.name}: {results[c.id][1]}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(
                [
                    {"id": c.id, "tag": c.tag, "name": c.name, "outcome": results[c.id][0], "detail": results[c.id][1]}
                    for c in chosen
                ],
                fh,
                indent=1,
            )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
