// The module's parts by API area, each adding its names to the module (module.cpp calls them in this order).
#pragma once

#include <pybind11/pybind11.h>

namespace mlsdeform::python {

void bind_deformer(pybind11::module_& m);  // Deformer (bind_deformer.cpp)
void bind_fits(pybind11::module_& m);      // fit_rotations, fit_rotation, fit_points (bind_fits.cpp)
void bind_frames(pybind11::module_& m);    // transform_normals, transform_tangents (bind_frames.cpp)
void bind_splats(pybind11::module_& m);    // rotate_splats, transform_splats_affine (bind_splats.cpp)
void bind_files(pybind11::module_& m);     // _Mesh, _read_handles, _frame_path: the files library (bind_files.cpp)
void bind_jobs(pybind11::module_& m);      // _DeformJob: the program's deform on files (bind_jobs.cpp)

}  // namespace mlsdeform::python
