// mlsdeform.transform_normals and mlsdeform.transform_tangents: oriented data carried through the per-vertex
// linear parts that Deformer.deform(linear=...) writes (mlsdeform/frames.hpp). The dtype follows `linear`'s
// (float32 stays float32, anything else float64); the data is converted to it, `out` must have it.
#include "python/src/arrays.hpp"
#include "python/src/bindings.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <span>
#include <string>
#include <vector>

namespace mlsdeform::python {
namespace {

/// linear (n, 3, 3) and data (n, width) converted to T; out None (a new array) or a C-contiguous, writeable
/// (n, width) array of T; then the library's function f (which checks finiteness, writing nothing on error).
template <class T, class F>
py::array_t<T> carry(const py::object& linear, const py::object& data, const py::object& out, py::ssize_t width,
                     const char* name, F&& f) {
  const Array<T> L = try_array<T>(linear);
  if (!L) throw py::type_error("linear: expected an (n, 3, 3) array of real numbers, got " + received(linear));
  if (L.ndim() != 3 || L.shape(1) != 3 || L.shape(2) != 3)
    throw py::value_error("linear: expected shape (n, 3, 3), got " + shape_of(L));
  const py::ssize_t n = L.shape(0);
  const std::string want = "(" + std::to_string(n) + ", " + std::to_string(width) + ")";
  const Array<T> x = try_array<T>(data);
  if (!x)
    throw py::type_error(std::string(name) + ": expected an " + want + " array of real numbers, got " + received(data));
  if (x.ndim() != 2 || x.shape(0) != n || x.shape(1) != width)
    throw py::value_error(std::string(name) + ": expected shape " + want + " (one row per linear part), got " +
                          shape_of(x));
  py::array_t<T> result;
  if (out.is_none()) {
    result = py::array_t<T>({n, width});
  } else {
    if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array");
    const py::array a = py::reinterpret_borrow<py::array>(out);
    if (!a.dtype().equal(py::dtype::of<T>()))
      throw py::type_error(std::string("out: expected dtype ") + (sizeof(T) == 4 ? "float32" : "float64") +
                           " (that of linear), got " + std::string(py::str(a.dtype())));
    if (a.ndim() != 2 || a.shape(0) != n || a.shape(1) != width)
      throw py::value_error("out: expected shape " + want + ", got " + shape_of(a));
    if (!(a.flags() & py::array::c_style)) throw py::value_error("out: must be C-contiguous");
    if (!a.writeable()) throw py::value_error("out: is read-only");
    result = py::reinterpret_borrow<py::array_t<T>>(out);
  }
  const auto size = std::size_t(n * width);
  // The library writes row by row and may write over its own input (out is data): where out overlaps linear,
  // or overlaps data shifted, a row written would be read later as input, so the results go to a scratch array
  // and reach out after all of both is read (as fit_rotations does).
  const bool overlaps =
      !out.is_none() && (may_share_memory(L, result) || (x.data() != result.data() && may_share_memory(x, result)));
  if (!overlaps) {
    f(std::span<const T>(L.data(), std::size_t(9 * n)), std::span<const T>(x.data(), size),
      std::span<T>(result.mutable_data(), size));
    return result;
  }
  std::vector<T> scratch(size);
  f(std::span<const T>(L.data(), std::size_t(9 * n)), std::span<const T>(x.data(), size), std::span<T>(scratch));
  std::copy(scratch.begin(), scratch.end(), result.mutable_data());
  return result;
}

bool is_single(const py::object& obj) {
  return py::isinstance<py::array>(obj) && py::reinterpret_borrow<py::array>(obj).dtype().equal(py::dtype::of<float>());
}

}  // namespace

void bind_frames(py::module_& m) {
  m.def(
      "transform_normals",
      [](const py::object& linear, const py::object& normals, const py::object& out) -> py::array {
        if (is_single(linear))
          return carry<float>(linear, normals, out, 3, "normals",
                              [](auto l, auto x, auto o) { transform_normals<float>(l, x, o); });
        return carry<double>(linear, normals, out, 3, "normals",
                             [](auto l, auto x, auto o) { transform_normals<double>(l, x, o); });
      },
      py::arg("linear"), py::arg("normals"), py::kw_only(), py::arg("out") = py::none(),
      R"(transform_normals(linear, normals, *, out=None) -> (n, 3) array

Normals carried through per-vertex linear parts (Deformer.deform(linear=...), (n, 3, 3)): L^-T n,
renormalised (for a rotation, R n). A zero normal stays zero; where L maps the normal to zero or to a
non-finite vector (L of rank 1 or 0), the input normal is kept, unit length. The dtype is linear's
(float32, else float64). out: None (a new array) or a C-contiguous (n, 3) array of that dtype (it may be
normals itself, or overlap normals or linear: the results then reach out after all of both is read). ValueError on a shape that does not match or a non-finite normal (nothing written).)");
  m.def(
      "transform_tangents",
      [](const py::object& linear, const py::object& tangents, const py::object& out) -> py::array {
        if (is_single(linear))
          return carry<float>(linear, tangents, out, 4, "tangents",
                              [](auto l, auto x, auto o) { transform_tangents<float>(l, x, o); });
        return carry<double>(linear, tangents, out, 4, "tangents",
                             [](auto l, auto x, auto o) { transform_tangents<double>(l, x, o); });
      },
      py::arg("linear"), py::arg("tangents"), py::kw_only(), py::arg("out") = py::none(),
      R"(transform_tangents(linear, tangents, *, out=None) -> (n, 4) array

Tangents (n, 4): x, y, z and the bitangent sign w (glTF's TANGENT), carried through per-vertex linear parts:
L t renormalised, w kept (negated where det L < 0: a reflection flips the frame's handedness). Where L t is
zero or not finite the input tangent is kept, unit length. dtype and out as transform_normals.)");
}

}  // namespace mlsdeform::python
