"""PLY for mlsdeform.files: read in ASCII or binary (either byte order), any vertex and face properties the
program accepts; written binary little-endian."""
import numpy as np

from ._files_faces import Faces

_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


def _read_ply(data, path):
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError(f"{path}: malformed PLY: no 'ply' ... 'end_header' header")
    body = data.index(b"\n", end) + 1
    fmt, elements = None, []
    for line in data[:end].decode("ascii", "replace").splitlines()[1:]:
        p = line.split()
        if not p or p[0] in ("comment", "obj_info"):
            continue
        if p[0] == "format" and len(p) == 3:
            fmt = p[1]
        elif p[0] == "element" and len(p) == 3:
            elements.append((p[1], int(p[2]), []))
        elif p[0] == "property" and elements and len(p) == 3 and p[1] in _PLY_TYPES:
            elements[-1][2].append((p[2], _PLY_TYPES[p[1]], None))
        elif (
            p[0] == "property"
            and elements
            and len(p) == 5
            and p[1] == "list"
            and p[2] in _PLY_TYPES
            and p[3] in _PLY_TYPES
        ):
            elements[-1][2].append((p[4], _PLY_TYPES[p[3]], _PLY_TYPES[p[2]]))
        else:
            raise ValueError(f"{path}: malformed PLY header line: {line!r}")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"{path}: malformed PLY: unknown format {fmt!r}")
    order = "<" if fmt == "binary_little_endian" else ">"
    V, faces = None, Faces([], [])
    tokens = data[body:].split() if fmt == "ascii" else None
    pos = 0
    for name, count, props in elements:
        if fmt == "ascii":
            values, pos = _ply_ascii_element(tokens, pos, count, props, path, name)
        else:
            values, pos = _ply_binary_element(data, body + pos, count, props, order, path, name)
            pos -= body
        if name == "vertex":
            try:
                V = np.stack([values[c] for c in ("x", "y", "z")], axis=1)
            except KeyError:
                raise ValueError(f"{path}: the vertex element has no x, y and z") from None
        elif name == "face":
            lists = [v for (pname, _, ctype), v in zip(props, values.values()) if ctype is not None]
            if not lists:
                raise ValueError(f"{path}: the face element has no vertex index list")
            faces = Faces(*lists[0])
    if V is None:
        raise ValueError(f"{path}: no vertex element")
    if np.any(faces.counts < 3):
        raise ValueError(f"{path}: a face has fewer than 3 vertices")
    return V, faces


def _ply_ascii_element(tokens, pos, count, props, path, name):
    if all(ctype is None for _, _, ctype in props):
        width = len(props)
        block = tokens[pos : pos + count * width]
        if len(block) != count * width:
            raise ValueError(f"{path}: malformed PLY: truncated in element {name}")
        try:
            np.array(block, dtype=np.float64)
        except ValueError:
            raise ValueError(f"{path}: malformed PLY: a value of element {name} is not a number") from None
        table = np.array(block, dtype="S").reshape(count, width)  # the text: rounded to the precision later
        return {p: table[:, i] for i, (p, _, _) in enumerate(props)}, pos + count * width
    columns = {p: [] for p, _, _ in props}
    try:
        for _ in range(count):
            for p, _, ctype in props:
                if ctype is None:
                    float(tokens[pos])  # a number, or ValueError
                    columns[p].append(tokens[pos])
                    pos += 1
                else:
                    n = int(tokens[pos])
                    columns[p].append([int(t) for t in tokens[pos + 1 : pos + 1 + n]])
                    pos += 1 + n
    except (IndexError, ValueError):
        raise ValueError(f"{path}: malformed PLY: truncated or not a number in element {name}") from None
    for p, _, ctype in props:
        if ctype is None:
            columns[p] = np.array(columns[p], dtype="S")
        else:
            lists = columns[p]
            columns[p] = (
                np.array([len(x) for x in lists], np.int64),
                np.fromiter((i for x in lists for i in x), np.int64),
            )
    return columns, pos


def _ply_binary_element(data, pos, count, props, order, path, name):
    lists = [p for p in props if p[2] is not None]
    if not lists:
        dtype = np.dtype([(p, order + t) for p, t, _ in props])
        if pos + count * dtype.itemsize > len(data):
            raise ValueError(f"{path}: malformed PLY: truncated in element {name}")
        table = np.frombuffer(data, dtype, count, pos)
        return {p: table[p] for p, _, _ in props}, pos + count * dtype.itemsize
    if len(props) == 1 and count:
        # The usual face element, one list: read as fixed records when every list has the first one's length.
        ((p, t, ctype),) = props
        first = int(np.frombuffer(data, order + ctype, 1, pos)[0])
        record = np.dtype([("n", order + ctype), ("i", order + t, (first,))])
        if first > 0 and pos + count * record.itemsize <= len(data):
            table = np.frombuffer(data, record, count, pos)
            if np.all(table["n"] == first):
                return {
                    p: (table["n"].astype(np.int64), table["i"].astype(np.int64).ravel())
                }, pos + count * record.itemsize
    columns = {p: [] for p, _, _ in props}
    try:
        for _ in range(count):
            for p, t, ctype in props:
                if ctype is None:
                    columns[p].append(np.frombuffer(data, order + t, 1, pos)[0])
                    pos += np.dtype(t).itemsize
                else:
                    n = int(np.frombuffer(data, order + ctype, 1, pos)[0])
                    pos += np.dtype(ctype).itemsize
                    columns[p].append(np.frombuffer(data, order + t, n, pos))
                    pos += n * np.dtype(t).itemsize
    except ValueError:
        raise ValueError(f"{path}: malformed PLY: truncated in element {name}") from None
    for p, _, ctype in props:
        if ctype is not None:
            lists = columns[p]
            columns[p] = (
                np.array([len(x) for x in lists], np.int64),
                np.concatenate(lists).astype(np.int64) if lists else np.zeros(0, np.int64),
            )
    return columns, pos


def _write_ply(f, V, faces):
    scalar = "double" if V.dtype == np.float64 else "float"
    m = len(faces) if faces is not None else 0
    f.write(
        (
            f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\nproperty {scalar} x\n"
            f"property {scalar} y\nproperty {scalar} z\nelement face {m}\n"
            "property list uchar int vertex_indices\nend_header\n"
        ).encode()
    )
    f.write(np.ascontiguousarray(V, dtype="<f8" if scalar == "double" else "<f4").data)
    if m:
        f.write(faces.ply_block().data)
