"""Mesh files and handles files in Python: the program's own readers and writers (the files library,
core/files/, compiled into the module), so a file reads, deforms and writes here exactly as `mlsdeform deform`
reads, deforms and writes it (docs/python.md, "Files").

    mesh = files.read_mesh("in.ply.gz")                # Mesh: vertices (n, 3), faces, every attribute it carries
    anim = files.read_handles("h.json", mesh.vertices)  # the program's handles file (docs/cli.md), resolved
    d = mlsdeform.Deformer(mesh.vertices, **anim.session_arguments())
    frames = mesh.frames_for("rigid")                  # the per-vertex frames its normals / splats need
    X = d.deform(**anim.targets(0), **frames)
    files.write_mesh("out.ply", mesh.deformed(X, **frames))   # normals and splats carried, the rest as read

    job = files.DeformJob("in.ply", "h.json", "out.ply")     # the program's `deform`, frame by frame
    for i in range(len(job.outputs)):
        job.write_frame(i)

Formats by file name, as the program's: read .obj, .off, .ply (ASCII, binary either byte order) and their .gz;
written the same and .npy (the positions alone). Coordinates are read in the precision asked for (float32 by
default, as the program's --precision), decimal text correctly rounded to it. Bad input raises ValueError with
the program's message (the file, the line or JSON path, the problem).
"""
import os
import re
import uuid

import numpy as np

from ._mlsdeform import _DeformJob, _Mesh, _frame_path, _read_handles

__all__ = [
    "Mesh",
    "Faces",
    "Animation",
    "DeformJob",
    "read_mesh",
    "write_mesh",
    "read_handles",
    "frame_path",
    "write_atomically",
]

_MAX_BYTES = 1 << 30  # the program's default --max-input-bytes


class Faces:
    """Polygons as `counts` (vertices per face) and `indices` (all faces' vertex indices, in order)."""

    def __init__(self, counts, indices):
        self.counts = np.asarray(counts, dtype=np.int64)
        self.indices = np.asarray(indices, dtype=np.int64)
        if self.counts.sum() != len(self.indices):
            raise ValueError("face counts do not add up to the number of indices")

    def __len__(self):
        return len(self.counts)

    def triangles(self):
        """(m, 3) vertex indices, or None unless every face is a triangle."""
        if len(self.counts) and np.all(self.counts == 3):
            return self.indices.reshape(-1, 3)
        return None if len(self.counts) else np.zeros((0, 3), np.int64)


class Mesh:
    """A mesh as read from a file, with everything the file carries besides positions and faces (PLY properties
    and elements, OBJ texture coordinates, normals, groups, materials, OFF colours, Gaussian splats), which
    write_mesh gives back: kept as read, or carried through each vertex's frame by deformed()."""

    def __init__(self, native):
        self._m = native

    @classmethod
    def from_arrays(cls, vertices, faces=None):
        """A mesh built in memory: vertices (n, 3) (float32 stays float32, anything else float64) and Faces (or
        an (m, 3) integer array of triangles, or None)."""
        if faces is None:
            counts, indices = np.zeros(0, np.int64), np.zeros(0, np.int64)
        elif isinstance(faces, Faces):
            counts, indices = faces.counts, faces.indices
        else:
            tri = np.asarray(faces)
            if tri.ndim != 2 or tri.shape[1] != 3:
                raise ValueError(f"faces: expected Faces or an (m, 3) array of triangles, got shape {tri.shape}")
            counts, indices = np.full(len(tri), 3, np.int64), tri.reshape(-1)
        return cls(_Mesh.from_arrays(vertices, counts, indices))

    @property
    def vertices(self):
        """(n, 3) positions, a new array of the mesh's dtype."""
        return self._m.vertices

    @property
    def faces(self):
        return Faces(*self._m.faces)

    @property
    def dtype(self):
        return self._m.dtype

    @property
    def path(self):
        """The file it was read from ('' for a mesh built from arrays)."""
        return self._m.path

    @property
    def splat_sh_degree(self):
        """A 3D Gaussian splat file's SH degree (docs/splats.md), or None."""
        d = self._m.splat_sh_degree
        return None if d < 0 else d

    def __iter__(self):
        """`V, faces = read_mesh(path)`, as before meshes carried their attributes."""
        return iter((self.vertices, self.faces))

    def frames_for(self, transform="rigid"):
        """Empty arrays for the per-vertex frames that carrying this mesh's attributes under `transform` needs,
        as keyword arguments of both Deformer.deform (which fills them) and deformed(): `linear` (n, 3, 3) for
        normals (and splats under an affine fit), `quaternions` (n, 4) for splats, `scales` (n,) for splats
        under a similarity fit. Empty for a mesh with nothing to carry."""
        return {k: np.empty(shape, self.dtype) for k, shape in self._m.frames_needed(transform).items()}

    def deformed(self, positions, *, linear=None, quaternions=None, scales=None):
        """A copy at `positions` (n, 3), its normals and splats carried through each vertex's frame as the
        program carries them (normals by L^-T; splats turned, grown, or mapped by an affine fit's L: the fit is
        told by what is given), every other attribute as read. ValueError naming what is missing when the mesh
        has normals or splats and their frames are not given (frames_for)."""
        return Mesh(self._m.deformed(positions, linear=linear, quaternions=quaternions, scales=scales))

    def attributes(self, out_path, normals="input"):
        """What writing to `out_path` does with the input's attributes: {"kept": [...], "transformed": [...],
        "dropped": [...]}, short phrases as the program prints them."""
        kept, transformed, dropped = self._m.attributes(out_path, normals)
        return {"kept": kept, "transformed": transformed, "dropped": dropped}

    def encode(self, path, *, ply_ascii=False, normals="input", output_type=None):
        """The bytes write_mesh writes for `path`."""
        return self._m.encode(path, ply_ascii, normals, output_type)


class Animation:
    """A resolved handles file: rest handles and one target set per output (the frames, or one).

    `points` (k, 3) and `segments` ((s, 3), (s, 3)) are the rest positions; `frames` a list of
    (points (k, 3), (segment_a (s, 3), segment_b (s, 3))) targets; `region` the vertex indices of "region" or
    None. Arrays have the dtype asked for; `targets(i)` gives frame i as keyword arguments of Deformer.deform."""

    def __init__(self, points, segments, frames, region, animated):
        self.points, self.segments, self.frames, self.region, self.animated = points, segments, frames, region, animated

    def session_arguments(self):
        """Keyword arguments of mlsdeform.Deformer for the rest pose."""
        kw = {}
        if len(self.points):
            kw["points"] = self.points
        if len(self.segments[0]):
            kw["segments"] = self.segments
        if self.region is not None:
            kw["region"] = self.region
        return kw

    def targets(self, i):
        points, segments = self.frames[i]
        kw = {}
        if len(points):
            kw["points"] = points
        if len(segments[0]):
            kw["segments"] = segments
        return kw


def read_mesh(path, dtype=np.float32, max_bytes=_MAX_BYTES):
    """Reads a mesh file (.obj, .off, .ply, or their .gz) with the program's reader: a Mesh."""
    return Mesh(_Mesh.read(os.fspath(path), dtype, max_bytes))


def read_handles(path, vertices, dtype=np.float32):
    """Reads the program's handles file (docs/cli.md) and resolves it against the mesh's `vertices` (a handle on
    a vertex takes its position exactly) in precision `dtype`, with the program's checks: an Animation."""
    if isinstance(vertices, Mesh):
        vertices = vertices.vertices
    return Animation(*_read_handles(os.fspath(path), vertices, dtype))


def frame_path(out, frame, frame_count):
    """The program's name of output `frame` of `frame_count`: out_0007.ply of 120 frames (the number zero-padded
    to the digits of the largest index, at least 4, before the format extension, through a .gz)."""
    return _frame_path(os.fspath(out), frame, frame_count)


def write_atomically(path, data, tag=""):
    """Writes the bytes `data` to a temporary file beside `path`, then renames it to `path`: readers never see a
    part of a file, and a run that dies leaves at most a temporary file `.NAME.TAG.*.tmp` (remove_temporaries)."""
    folder, name = os.path.split(os.path.abspath(path))
    tmp = os.path.join(folder, f".{name}.{tag}.{uuid.uuid4().hex}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
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


def write_mesh(path, mesh, faces=None, *, ply_ascii=False, normals="input", output_type=None, tag=""):
    """Writes `mesh` (a Mesh, or vertices (n, 3) with `faces`: Faces, (m, 3) triangles or None) by the file
    name with the program's writer (.obj, .off, .ply binary or ASCII, their .gz, and .npy), all or nothing (a
    temporary file, then a rename; an existing file is replaced). `normals`: "input" (the mesh's own) or
    "computed" (from the faces); `output_type`: None (the mesh's), "float32" or "float64". Returns the bytes
    written."""
    if not isinstance(mesh, Mesh):
        mesh = Mesh.from_arrays(mesh, faces)
    elif faces is not None:
        raise ValueError("write_mesh: faces= is for vertices given as an array; a Mesh has its own")
    path = os.fspath(path)
    data = mesh.encode(path, ply_ascii=ply_ascii, normals=normals, output_type=output_type)
    write_atomically(path, data, tag)
    return len(data)


class DeformJob:
    """The program's `mlsdeform deform` on files, frame by frame: the mesh file and the handles file read and
    checked, every output's name checked (existing ones refused unless overwrite=True), the deformer built, all
    before any frame. encode_frame(i) gives output i's bytes, exactly the program's for the same options;
    write_frame(i) writes them all or nothing. `options`: Deformer's (transform=, exponent=, method=,
    weight_storage=, arap_iterations=, ...); `normals`, `ply_ascii`, `output_type`, `strict_attributes`: the
    program's --normals, --ply-ascii, --output-type, --strict-attributes."""

    def __init__(
        self,
        mesh,
        handles,
        out,
        *,
        dtype=np.float32,
        normals="input",
        ply_ascii=False,
        output_type=None,
        strict_attributes=False,
        overwrite=False,
        max_input_bytes=_MAX_BYTES,
        **options,
    ):
        self._job = _DeformJob(
            os.fspath(mesh),
            os.fspath(handles),
            os.fspath(out),
            dtype=dtype,
            normals=normals,
            ply_ascii=ply_ascii,
            output_type=output_type,
            strict_attributes=strict_attributes,
            overwrite=overwrite,
            max_input_bytes=max_input_bytes,
            **options,
        )
        self.outputs = list(self._job.outputs)
        self.summary = dict(self._job.summary)

    def encode_frame(self, i):
        """(bytes of output i, seconds deforming, seconds carrying attributes and encoding). One frame at a time
        per job (it reuses its buffers): threads that share a job take turns (a lock), or each has its own."""
        return self._job.encode_frame(i)

    def write_frame(self, i, tag=""):
        """Writes output i (all or nothing; replaces an existing file); returns its size in bytes."""
        data, _, _ = self._job.encode_frame(i)
        write_atomically(self.outputs[i], data, tag)
        return len(data)
