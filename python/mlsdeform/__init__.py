"""mlsdeform: as-rigid-as-possible deformation of 3D models by Moving Least Squares (Cuno, Esperanca,
Oliveira, Cavalcanti, "3D As-Rigid-As-Possible Deformations Using MLS"), and the batched weighted rotation
fit at its heart. numpy in, numpy out; the C++ library does the work with the GIL released.

    import numpy as np, mlsdeform
    d = mlsdeform.Deformer(V, points=P)          # V: (n, 3), P: (k, 3) rest positions of the handles
    X = d.deform(points=Q)                        # Q: (k, 3) moved handles -> (n, 3) deformed vertices
    d.deform(points=Q, out=X)                     # per frame: written in place, no copy

See docs/python.md for the whole API.
"""
from ._mlsdeform import (
    Deformer,
    __version__,
    active_isa,
    fit_points,
    fit_rotation,
    fit_rotations,
    rotate_splats,
    set_isa,
    supported_isas,
    transform_normals,
    transform_splats_affine,
    transform_tangents,
)

__all__ = [
    "Deformer",
    "__version__",
    "active_isa",
    "fit_points",
    "fit_rotation",
    "fit_rotations",
    "rotate_splats",
    "set_isa",
    "supported_isas",
    "transform_normals",
    "transform_splats_affine",
    "transform_tangents",
]
