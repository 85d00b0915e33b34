// The mesh object behind mlsdeform.files.Mesh: a files::BasicMesh in float or double, as the files library
// (core/files/) read it, with every attribute of the file (bind_files.cpp binds it).
#pragma once

#include "core/files/mesh.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <variant>
#include <vector>

namespace mlsdeform::python {

namespace py = pybind11;

struct PyMesh {
  std::variant<files::BasicMesh<float>, files::BasicMesh<double>> mesh;
  std::string path;  ///< the file it was read from, naming it in messages ("" for arrays)

  template <class F>
  decltype(auto) visit(F&& f) const {
    return std::visit(std::forward<F>(f), mesh);
  }
  py::dtype dtype() const { return mesh.index() == 0 ? py::dtype::of<float>() : py::dtype::of<double>(); }

  /// read_mesh in float (dtype float32) or double (float64), GIL released.
  static PyMesh read(const std::string& path, const py::object& dtype, std::size_t max_bytes);
  /// A mesh built in memory: vertices (n, 3) (its dtype: float32 stays float, else double) and polygons as
  /// counts and indices (checked: each count >= 3, indices in range).
  static PyMesh from_arrays(const py::object& vertices, const py::object& counts, const py::object& indices);
  /// {"linear": (n, 3, 3), ...}: the frames that carrying this mesh's attributes under `transform` needs.
  py::dict frames_needed(const std::string& transform) const;
  /// (kept, transformed, dropped) of the attributes when written to `out_path` ("input" or "computed" normals).
  py::tuple attributes(const std::string& out_path, const std::string& normals) const;
  /// The bytes of `path`'s format (the program's encoder); output_type None, "float32" or "float64".
  py::bytes encode(const std::string& out_path, bool ply_ascii, const std::string& normals,
                   const py::object& output_type) const;
};

/// A handles file resolved against `vertices` in precision `dtype` (the program's rules): (points (k, 3),
/// (A (s, 3), B (s, 3)), frames [(points, (A, B)), ...], region (int64) or None, animated).
py::tuple read_handles_arrays(const std::string& path, const py::object& vertices, const py::object& dtype);

/// float32 -> true, float64 -> false; anything else TypeError.
bool single_precision(const py::object& dtype);

files::NormalsOut parse_normals(const std::string& normals);
std::optional<files::CoordinateType> parse_output_type(const py::object& output_type);

}  // namespace mlsdeform::python
