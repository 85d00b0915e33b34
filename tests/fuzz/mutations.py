"""The mutants of the mutation campaign (mutation_campaign.py): a generated seed mesh, encoded in every format
the program reads, and byte, token, header, binary-layout and gzip mutations of it."""
import gzip
import struct


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


SPLAT_KINDS = ("spz", "splat", "compressed.ply")


def splat_seeds(corpus_dir):
    """The splat seeds (tests/fuzz/corpus_*, written by splat-transform and by hand): the mutation bases."""
    import glob
    import os

    seeds = {}
    for kind in SPLAT_KINDS:
        folder = os.path.join(corpus_dir, "corpus_" + kind.replace(".", "_"))
        seeds[kind] = [open(f, "rb").read() for f in sorted(glob.glob(os.path.join(folder, "*")))]
    return seeds


def make_splat_mutant(kind, seeds, rng):
    """A splat file mutated: bytes anywhere, a compressed PLY's header, an SPZ's gzip layer or the data inside it."""
    data = rng.choice(seeds[kind])
    r = rng.random()
    if kind == "spz" and data[:2] == b"\x1f\x8b":
        if r < 0.3:
            return mutate_gzip(data, rng)
        if r < 0.7:
            return gzip.compress(mutate_bytes(gzip.decompress(data), rng), mtime=0)
    if kind == "compressed.ply" and r < 0.4:
        return mutate_header(data, rng)
    return mutate_bytes(data, rng)
