"""Mesh files and handles files in Python, for jobs that run without the `mlsdeform` program (mlsdeform.dask).

    V, faces = files.read_mesh("in.ply.gz")          # float32 (n, 3), Faces
    anim = files.read_handles("h.json", V)           # the program's handles file (docs/cli.md), resolved
    files.write_mesh("out.ply", X, faces)            # all or nothing: a temporary file, then a rename

Formats by file name: `.obj`, `.ply` (ASCII or binary, read; binary little-endian, written), `.gz` of either
(read), and `.npy` (written: the vertices only). Coordinates are read as the program reads them: in the
precision asked for (float32 by default, as its `--precision`), decimal text correctly rounded to it.
The handles file is resolved as the program resolves it (targets in double, rounded once to the session's
precision), so the same file gives bitwise the same handles here and in `mlsdeform deform`.
Bad input raises ValueError naming the file and, for a handles file, the JSON path of the problem.
"""
import gzip
import os
import re
import uuid
from fractions import Fraction

import numpy as np

from ._files_faces import Faces
from ._files_handles import Animation, read_handles
from ._files_obj import _read_obj, _write_obj
from ._files_ply import _read_ply, _write_ply

__all__ = ["Faces", "Animation", "read_mesh", "write_mesh", "read_handles", "write_atomically"]

# The classes live beside their format's code; pickles (Dask sends them to workers) and help() name them by
# this public module, as before the split.
Faces.__module__ = Animation.__module__ = __name__


# ---- reading meshes -----------------------------------------------------------------------------------------


def _open(path):
    with open(path, "rb") as f:
        magic = f.read(2)
    return gzip.open(path, "rb") if magic == b"\x1f\x8b" else open(path, "rb")


def read_mesh(path, dtype=np.float32):
    """Reads an OBJ or PLY file (or its .gz): (vertices (n, 3) of `dtype`, Faces)."""
    name = path[:-3] if path.endswith(".gz") else path
    ext = os.path.splitext(name)[1].lower()
    if ext not in (".obj", ".ply"):
        raise ValueError(f"{path}: unknown mesh format (.obj, .ply, and their .gz)")
    try:
        with _open(path) as f:
            data = f.read()
    except OSError as e:
        raise ValueError(f"{path}: cannot read: {e.strerror or e}") from e
    coords, faces = (_read_obj if ext == ".obj" else _read_ply)(data, path)
    V = _decimals(coords, dtype) if coords.dtype.kind in "SU" else coords.astype(dtype)
    if not np.isfinite(V).all():
        raise ValueError(f"{path}: a vertex has a non-finite coordinate")
    if len(faces.indices) and (faces.indices.min() < 0 or faces.indices.max() >= len(V)):
        raise ValueError(f"{path}: a face refers to a vertex out of range (the mesh has {len(V)} vertices)")
    return V, faces


def _decimals(text, dtype):
    """Decimal strings to `dtype`, correctly rounded (as std::from_chars). Through double, which is correctly
    rounded; to float32 that is right except where the double lands exactly halfway between two floats, where
    the decimal itself may lie on either side: those are settled exactly."""
    x = text.astype(np.float64)
    if np.dtype(dtype) == np.float64:
        return x
    f = x.astype(np.float32)
    other = np.where(x > f, np.nextafter(f, np.float32(np.inf)), np.nextafter(f, np.float32(-np.inf)))
    tie = (x != f) & ((f.astype(np.float64) + other.astype(np.float64)) / 2 == x)
    for i in zip(*np.nonzero(tie)):
        exact, half = Fraction(str(text[i], "ascii") if text.dtype.kind == "S" else text[i]), Fraction(x[i])
        if exact != half and (exact > half) == (other[i] > f[i]):
            f[i] = other[i]
    return f.astype(dtype, copy=False)


# ---- writing ------------------------------------------------------------------------------------------------


def write_atomically(path, write, tag=""):
    """Calls write(file) on a temporary file beside `path`, then renames it to `path`: readers never see a part
    of a file, and a run that dies leaves at most a temporary file `.NAME.TAG.*.tmp` (remove_temporaries)."""
    folder, name = os.path.split(os.path.abspath(path))
    tmp = os.path.join(folder, f".{name}.{tag}.{uuid.uuid4().hex}.tmp")
    try:
        with open(tmp, "wb") as f:
            write(f)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def remove_temporaries(folder, tag):
    """Removes the temporary files write_atomically(..., tag) left in `folder` (runs that died); their count."""
    pattern = re.compile(r"^\..*\." + re.escape(tag) + r"\.[0-9a-f]{32}\.tmp$")
    removed = 0
    for name in os.listdir(folder):
        if pattern.match(name):
            try:
                os.unlink(os.path.join(folder, name))
                removed += 1
            except FileNotFoundError:
                pass
    return removed


def write_mesh(path, vertices, faces=None, tag=""):
    """Writes `vertices` (n, 3) and `faces` (Faces, or None) by the file name: .ply (binary little-endian),
    .obj, or .npy (the vertices alone), all or nothing (write_atomically). Returns the bytes written."""
    ext = os.path.splitext(path)[1].lower()
    V = np.ascontiguousarray(vertices)
    if ext == ".npy":
        write_atomically(path, lambda f: np.save(f, V), tag)
    elif ext == ".ply":
        write_atomically(path, lambda f: _write_ply(f, V, faces), tag)
    elif ext == ".obj":
        write_atomically(path, lambda f: _write_obj(f, V, faces), tag)
    else:
        raise ValueError(f"{path}: unknown output format (.ply, .obj, .npy)")
    return os.path.getsize(path)
