"""mlsdeform.files.Faces: polygons of any size, and their face element as a binary PLY writes it."""
import numpy as np


class Faces:
    """Polygons as `counts` (vertices per face) and `indices` (all faces' vertex indices, in order)."""

    def __init__(self, counts, indices):
        self.counts = np.asarray(counts, dtype=np.int64)
        self.indices = np.asarray(indices, dtype=np.int64)
        if self.counts.sum() != len(self.indices):
            raise ValueError("face counts do not add up to the number of indices")

    def __len__(self):
        return len(self.counts)

    def ply_block(self):
        """The face element of a binary little-endian PLY (a uchar count, then int indices, per face): encoded
        once and kept, since every frame of an animation writes the same faces."""
        block = getattr(self, "_ply", None)
        if block is None:
            block = self._ply = _encode_ply_faces(self)
        return block

    def __getstate__(self):
        return {"counts": self.counts, "indices": self.indices}  # not the encodings: they are remade where used

    def triangles(self):
        """(m, 3) vertex indices, or None unless every face is a triangle."""
        if len(self.counts) and np.all(self.counts == 3):
            return self.indices.reshape(-1, 3)
        return None if len(self.counts) else np.zeros((0, 3), np.int64)


def _encode_ply_faces(faces):
    m = len(faces)
    if np.any(faces.counts > 255):
        raise ValueError("a face has more than 255 vertices (PLY's uchar count)")
    tri = faces.triangles()
    if tri is not None:
        rec = np.empty(m, np.dtype([("n", "u1"), ("i", "<i4", (3,))]))
        rec["n"] = 3
        rec["i"] = tri
        return rec.view(np.uint8)
    # Each face: its count (one byte), then its indices (4 bytes each).
    starts = np.concatenate(([0], np.cumsum(1 + 4 * faces.counts)[:-1]))
    buf = np.zeros(int(m + 4 * faces.counts.sum()), np.uint8)
    buf[starts] = faces.counts
    offsets = np.repeat(starts + 1, faces.counts) + 4 * (
        np.arange(len(faces.indices)) - np.repeat(np.cumsum(faces.counts) - faces.counts, faces.counts)
    )
    idx = faces.indices.astype("<i4").view(np.uint8).reshape(-1, 4)
    for b in range(4):
        buf[offsets + b] = idx[:, b]
    return buf
