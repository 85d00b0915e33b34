#!/usr/bin/env python3
"""Mutation campaign for the mesh readers of the `mlsdeform` program, run as a user runs it.

Generates a small valid mesh in every readable format (OBJ, OFF, PLY ASCII, PLY binary little- and big-endian,
and the .gz of each), mutates each file N times (bytes, tokens, header counts, gzip members; a few gzip bombs),
runs `mlsdeform deform` on every mutant with a fresh output folder, and checks the program's contract:

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
import gzip
import json
import os
import random
import resource
import shutil
import struct
import subprocess
import sys
import threading
import time
import zlib


def seed_mesh():
    """A cube subdivided 6 x 6 per side (vertices shared along edges), quads and triangles: 218 vertices."""
    n = 6
    index, verts, faces = {}, [], []

    def vid(p):
        key = tuple(round(c, 9) for c in p)
        if key not in index:
            index[key] = len(verts)
            verts.append(p)
        return index[key]

    for axis in range(3):
        for side in (0.0, 1.0):
            for i in range(n):
                for j in range(n):

                    def point(a, b):
                        p = [0.0, 0.0, 0.0]
                        p[axis], p[(axis + 1) % 3], p[(axis + 2) % 3] = side, a / n, b / n
                        return tuple(p)

                    q = [vid(point(i, j)), vid(point(i + 1, j)), vid(point(i + 1, j + 1)), vid(point(i, j + 1))]
                    faces.append(q if (i + j) % 3 else q[:3])
                    if not (i + j) % 3:
                        faces.append([q[0], q[2], q[3]])
    return verts, faces


def encode(verts, faces, kind, ply_type="float"):
    if kind == "obj":
        return (
            "# seed\n"
            + "".join("v %r %r %r\n" % v for v in verts)
            + "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in faces)
        ).encode()
    if kind == "off":
        return (
            "OFF\n%d %d 0\n" % (len(verts), len(faces))
            + "".join("%r %r %r\n" % v for v in verts)
            + "".join("%d %s\n" % (len(f), " ".join(map(str, f))) for f in faces)
        ).encode()
    fmt = {"ply": "ascii", "le.ply": "binary_little_endian", "be.ply": "binary_big_endian"}[kind]
    head = (
        "ply\nformat %s 1.0\nelement vertex %d\nproperty %s x\nproperty %s y\nproperty %s z\n"
        "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
        % (fmt, len(verts), ply_type, ply_type, ply_type, len(faces))
    )
    if fmt == "ascii":
        return (
            head
            + "".join("%r %r %r\n" % v for v in verts)
            + "".join("%d %s\n" % (len(f), " ".join(map(str, f))) for f in faces)
        ).encode()
    e = "<" if fmt == "binary_little_endian" else ">"
    body = b"".join(struct.pack(e + ("3f" if ply_type == "float" else "3d"), *v) for v in verts)
    body += b"".join(struct.pack(e + "B", len(f)) + struct.pack(e + "%di" % len(f), *f) for f in faces)
    return head.encode() + body


WEIRD = [
    b"-1",
    b"0",
    b"4294967295",
    b"4294967296",
    b"-2147483649",
    b"1e39",
    b"-1e39",
    b"nan",
    b"inf",
    b"0x1p3",
    b"1.5.5",
    b"",
    b"+",
    b"1e",
    b"=",
    b"3.4028236e38",
    b"1e-50",
    b"255",
    b"256",
    b"99999999999999999999",
    b"1e-46",
    b"1e309",
    b"1e-330",
    b"4.9e-324",
    b"1.7976931348623157e308",
    b"5000000.123",
    b"\xef\xbb\xbf",
]


def mutate_bytes(data, rng):
    data = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(6)
        at = rng.randrange(len(data) + 1) if data else 0
        if op == 0 and data:  # flip bits of a byte
            data[min(at, len(data) - 1)] ^= 1 << rng.randrange(8)
        elif op == 1 and data:  # replace a byte
            data[min(at, len(data) - 1)] = rng.randrange(256)
        elif op == 2:  # insert random bytes
            data[at:at] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
        elif op == 3:  # delete a range
            del data[at : at + rng.randint(1, 64)]
        elif op == 4:  # truncate
            del data[at:]
        else:  # duplicate a range
            data[at:at] = data[at : at + rng.randint(1, 256)]
    return bytes(data)


def mutate_tokens(data, rng):
    lines = data.split(b"\n")
    for _ in range(rng.randint(1, 3)):
        op = rng.randrange(6)
        i = rng.randrange(len(lines))
        tokens = lines[i].split(b" ")
        if op <= 1 and tokens:  # a number (or keyword) replaced by an awkward one, or one that is off by a little
            k = rng.randrange(len(tokens))
            if op == 0 or not tokens[k].lstrip(b"-").isdigit():
                tokens[k] = rng.choice(WEIRD)
            else:
                tokens[k] = str(int(tokens[k]) + rng.choice([-2, -1, 1, 2, 1000])).encode()
            lines[i] = b" ".join(tokens)
        elif op == 2:  # remove a line
            del lines[i]
        elif op == 3:  # swap two lines
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == 4:  # a line duplicated
            lines.insert(i, lines[i])
        else:  # trailing garbage
            lines.append(rng.choice([b"3 0 1 2", b"v 0 0 0", b"garbage", b"\x00\x01"]))
        if not lines:
            lines = [b""]
    return b"\n".join(lines)


def mutate_header(data, rng):
    """PLY and OFF headers: counts, types and format lines."""
    head_end = data.find(b"end_header\n")
    cut = head_end if head_end >= 0 else min(len(data), 40)
    head, body = data[:cut], data[cut:]
    swaps = [
        (b"float", rng.choice([b"double", b"uchar", b"int", b"float64", b"list"])),
        (b"uchar int", rng.choice([b"int int", b"uchar float", b"char uint", b"uint uchar"])),
        (b"binary_little_endian", b"binary_big_endian"),
        (b"binary_big_endian", b"ascii"),
        (b"ascii", b"binary_little_endian"),
        (b"1.0", b"2.0"),
        (b"vertex_indices", b"vertex_index"),
    ]
    old, new = rng.choice(swaps)
    head = head.replace(old, new, 1)
    return mutate_tokens(head, rng) + body if rng.random() < 0.5 else head + body


AWKWARD_INDEX = [-1, -2147483648, 2147483647, 4294967295, 218, 219, 65536, 0]


def mutate_binary(data, rng):
    """Binary PLY: a face's vertex count byte or one of its 32-bit indices, at a random face."""
    data = bytearray(data)
    pos = data.find(b"end_header\n") + len(b"end_header\n")
    nv = int(data[:pos].split(b"element vertex ")[1].split(b"\n")[0])
    e = "<" if b"little" in data[:pos] else ">"
    pos += (24 if b"property double x" in data[:pos] else 12) * nv
    records = []
    while pos < len(data):
        records.append(pos)
        pos += 1 + 4 * data[pos]
    for _ in range(rng.randint(1, 3)):
        at = rng.choice(records)
        if rng.random() < 0.4:
            data[at] = rng.choice([0, 1, 2, 5, 255, data[at] - 1, data[at] + 1])
        else:
            k = at + 1 + 4 * rng.randrange(max(1, data[at]))
            data[k : k + 4] = struct.pack(e + "I", rng.choice(AWKWARD_INDEX) & 0xFFFFFFFF)
    return bytes(data)


def mutate_gzip(packed, rng):
    """The compressed bytes: the 10-byte header, the trailer (CRC-32, ISIZE), the body, or a member after it."""
    data = bytearray(packed)
    where = rng.randrange(4)
    if where == 0:  # header: magic, method, flags (FEXTRA/FNAME/FCOMMENT/FHCRC without their fields), OS
        at = rng.randrange(10)
        data[at] = rng.choice([0, 0xFF, data[at] ^ (1 << rng.randrange(8))])
    elif where == 1:  # trailer: CRC-32 or ISIZE changed, or cut
        at = len(data) - 8 + rng.randrange(8)
        if rng.random() < 0.3:
            del data[at:]
        else:
            data[at] ^= 1 << rng.randrange(8)
    elif where == 2:  # the deflate stream
        return bytes(data[:10]) + mutate_bytes(bytes(data[10:-8]), rng) + bytes(data[-8:])
    else:  # a second member (valid, mutated, or garbage) or trailing bytes
        data += rng.choice([packed, mutate_bytes(packed, rng), b"\x1f\x8b", b"\x00" * 8, b"garbage\n"])
    return bytes(data)


def make_mutant(kind, base, rng):
    text = kind in ("obj", "off", "ply")
    r = rng.random()
    if kind.endswith(".gz"):
        inner = kind[:-3]
        if r < 0.2:
            return mutate_bytes(gzip.compress(base[inner], mtime=0), rng)
        if r < 0.45:
            return mutate_gzip(gzip.compress(base[inner], mtime=0), rng)
        return gzip.compress(make_mutant(inner, base, rng), mtime=0)
    if text and r < 0.5:
        return mutate_tokens(base[kind], rng)
    if not text and r < 0.35:
        return mutate_binary(base[kind], rng)
    if kind != "obj" and r < 0.75:
        return mutate_header(base[kind], rng)
    return mutate_bytes(base[kind], rng)


# GNU time (Debian's `time` package) measures the program's own peak RSS. Without it, the child's rusage is
# used, which also counts this script's pages that the child shares between fork and exec (printed as a floor).
TIME = shutil.which("time", path="/usr/bin:/bin")


def run_one(program, path, out_dir, timeout, extra):
    """Runs the program on one mesh; (exit code, bug or None, peak RSS MiB, seconds, stderr)."""
    os.makedirs(out_dir)
    out = os.path.join(out_dir, "out.ply")
    err_path = path + ".stderr"
    handles = os.path.join(os.path.dirname(out_dir), "handles.json")
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
    # Two handles at different positions: vertex 0 fixed, the last one moved.
    with open(os.path.join(args.out_dir, "handles.json"), "w") as f:
        json.dump({"points": [{"vertex": 0}, {"vertex": len(verts) - 1, "offset": [0, 0.1, 0]}]}, f)
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
        if data is None:
            data = make_mutant(kind, base, random.Random("%d/%s/%d" % (args.seed, kind, i)))
        else:
            extra += ["--max-input-mib", "64"]
        path = os.path.join(args.out_dir, "m%05d.%s" % (i, kind))
        with open(path, "wb") as f:
            f.write(data)
        del data
        result = run_one(args.program, path, os.path.join(args.out_dir, "o_%s_%d" % (kind, i)), args.timeout, extra)
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
