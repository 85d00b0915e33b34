"""Wavefront OBJ for mlsdeform.files: vertices and faces, read as the program reads them, written with the
digits that read back the same value."""
import numpy as np

from ._files_faces import Faces


def _read_obj(data, path):
    vertices, counts, indices = [], [], []
    for number, line in enumerate(data.decode("utf-8", "replace").splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            if len(parts) not in (4, 5, 7):
                raise ValueError(f"{path}: line {number}: a vertex needs 3 coordinates (or 4, or 6 with a colour)")
            try:
                [float(x) for x in parts[1:4]]  # noqa: B018 - checks that they are numbers
                vertices.append(parts[1:4])
            except ValueError:
                raise ValueError(f"{path}: line {number}: a coordinate is not a number") from None
        elif parts[0] == "f":
            if len(parts) < 4:
                raise ValueError(f"{path}: line {number}: a face needs at least 3 vertices")
            n = len(vertices)
            try:
                face = [int(p.split("/")[0]) for p in parts[1:]]
            except ValueError:
                raise ValueError(f"{path}: line {number}: a vertex index is not a whole number") from None
            # OBJ counts from 1; a negative index counts back from the last vertex read so far.
            face = [i - 1 if i > 0 else n + i for i in face]
            if any(i < 0 for i in face):
                raise ValueError(f"{path}: line {number}: vertex index out of range")
            counts.append(len(face))
            indices.extend(face)
    return np.array(vertices, dtype=str).reshape(-1, 3), Faces(counts, indices)


def _write_obj(f, V, faces):
    # float32 needs 9 significant digits to read back the same, float64 17.
    digits = 17 if V.dtype == np.float64 else 9
    f.write("".join(f"v {x:.{digits}g} {y:.{digits}g} {z:.{digits}g}\n" for x, y, z in V.tolist()).encode())
    if faces is not None and len(faces):
        ends = np.cumsum(faces.counts)
        one = (faces.indices + 1).tolist()
        lines, start = [], 0
        for end in ends.tolist():
            lines.append("f " + " ".join(map(str, one[start:end])) + "\n")
            start = end
        f.write("".join(lines).encode())
