"""mlsdeform: as-rigid-as-possible deformation of 3D models by Moving Least Squares (Cuno, Esperanca,
Oliveira, Cavalcanti, "3D As-Rigid-As-Possible Deformations Using MLS"), and the batched weighted rotation
fit at its heart. numpy in, numpy out; the C++ library does the work with the GIL released.

    import numpy as np, mlsdeform
    d = mlsdeform.Deformer(V, points=P)          # V: (n, 3), P: (k, 3) rest positions of the handles
    X = d.deform(points=Q)                        # Q: (k, 3) moved handles -> (n, 3) deformed vertices
    d.deform(points=Q, out=X)                     # per frame: written in place, no copy

See docs/python.md for the whole API.
"""
try:
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
except ModuleNotFoundError as _e:
    if _e.name != __name__ + "._mlsdeform":
        raise

    def _missing_module(error):
        """The compiled module is not beside these files: say which folder was imported, and why that happens."""
        import os
        import sys

        here = os.path.dirname(os.path.abspath(__file__))
        parent = os.path.dirname(here)
        others = [
            p
            for p in sys.path
            if os.path.abspath(p or os.curdir) != parent
            and os.path.isfile(os.path.join(p or os.curdir, __name__, "__init__.py"))
        ]
        text = f"mlsdeform: the compiled module _mlsdeform is not in {here}, the package Python imported: " + (
            f"a source folder (a checkout's python/) that comes on sys.path before the installed package in "
            f"{others[0]}; run from another folder, or put the build's python/ folder (build/python) first"
            if others
            else "a source folder (a checkout's python/) without the built module; build it (docs/python.md) and "
            "put the build's python/ folder (build/python) on PYTHONPATH, or install the package"
        )
        return ImportError(text, name=__name__ + "._mlsdeform", path=here)

    raise _missing_module(_e) from None


def _check_numpy(numpy_version, pybind11_version):
    """ImportError where this build's pybind11 cannot read the installed numpy's arrays: numpy 2 changed the layout
    of its array descriptors, which pybind11 reads with its own copy of it, and knows numpy 2's from 2.12 on (a
    wheel built on Debian 12 has pybind11 2.10). Computing anyway could read wrong sizes: refused at import."""
    major = int(str(numpy_version).split(".")[0])
    if major >= 2 and tuple(pybind11_version) < (2, 12):
        built = ".".join(map(str, pybind11_version))
        raise ImportError(
            f"mlsdeform: this build was compiled with pybind11 {built}, which supports numpy 1 only, and numpy "
            f"{numpy_version} is installed; install numpy<2 in this environment (pip install 'numpy<2'), or use "
            "a build of mlsdeform made with pybind11 2.12 or newer (Debian 13's python3-pybind11, for example)"
        )


def _numpy_version():
    import numpy

    return numpy.__version__


from ._mlsdeform import _pybind11_version  # noqa: E402 - after the check that the module is there

_check_numpy(_numpy_version(), _pybind11_version)

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
