// The splat functions (mlsdeform/splats.hpp): per-splat arrays of numpy updated in place by per-splat transforms.
// The arrays to update must be C-contiguous, writeable and of one dtype, float32 or float64 (a copy would
// silently leave the caller's array as it was); the transforms are converted to that dtype.
#include "python/src/arrays.hpp"
#include "python/src/bindings.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <optional>
#include <string>

namespace mlsdeform::python {
namespace {

/// One of the arrays updated in place: None, or a C-contiguous writeable array of T with n rows of `width`
/// values (shape (n, width), or (n, 3, width / 3) for sh_rest).
template <class T>
T* in_place(const py::object& obj, const char* name, py::ssize_t n, py::ssize_t width) {
  if (obj.is_none()) return nullptr;
  if (!py::isinstance<py::array>(obj)) throw py::type_error(std::string(name) + ": expected a numpy array");
  py::array a = py::reinterpret_borrow<py::array>(obj);
  if (!a.dtype().equal(py::dtype::of<T>()))
    throw py::type_error(std::string(name) + ": expected dtype " + (sizeof(T) == 4 ? "float32" : "float64") +
                         " (that of the splat arrays), got " + std::string(py::str(a.dtype())));
  const bool flat = a.ndim() == 2 && a.shape(0) == n && a.shape(1) == width;
  const bool channels = a.ndim() == 3 && a.shape(0) == n && a.shape(1) == 3 && a.shape(2) * 3 == width;
  if (!flat && !channels)
    throw py::value_error(std::string(name) + ": expected shape (" + std::to_string(n) + ", " + std::to_string(width) +
                          "), got " + shape_of(a));
  if (!(a.flags() & py::array::c_style)) throw py::value_error(std::string(name) + ": must be C-contiguous");
  if (!a.writeable()) throw py::value_error(std::string(name) + ": is read-only");
  return static_cast<T*>(a.mutable_data());
}

/// The dtype of the arrays to update: that of the first one given.
bool single(const py::object& rotations, const py::object& log_scales, const py::object& sh_rest) {
  for (const py::object* o : {&rotations, &log_scales, &sh_rest})
    if (!o->is_none() && py::isinstance<py::array>(*o))
      return py::reinterpret_borrow<py::array>(*o).dtype().equal(py::dtype::of<float>());
  return false;
}

/// f_rest's width: 9, 24 or 45 values (or (3, k) with k = 3, 8, 15), the SH degree 1, 2 or 3.
int sh_degree(const py::object& sh_rest) {
  if (sh_rest.is_none()) return 0;
  if (!py::isinstance<py::array>(sh_rest)) throw py::type_error("sh_rest: expected a numpy array");
  const py::array a = py::reinterpret_borrow<py::array>(sh_rest);
  const int width = a.ndim() == 2 ? int(a.shape(1)) : a.ndim() == 3 ? int(a.shape(1) * a.shape(2)) : -1;
  const int degree = width > 0 ? splat_sh_degree_of(width) : -1;
  if (degree < 1)
    throw py::value_error(
        "sh_rest: expected shape (n, 9), (n, 24) or (n, 45) (f_rest_* of SH degree 1, 2, 3; or "
        "(n, 3, k)), got " +
        shape_of(a));
  return degree;
}

template <class T>
Array<T> transform(const py::object& obj, const char* name, const char* shape) {
  const Array<T> a = try_array<T>(obj);
  if (!a)
    throw py::type_error(std::string(name) + ": expected an " + shape + " array of real numbers, got " + received(obj));
  return a;
}

template <class T>
void rotate_t(const py::object& quaternions, const py::object& scales, const py::object& rotations,
              const py::object& log_scales, const py::object& sh_rest, int threads) {
  const Array<T> q = transform<T>(quaternions, "quaternions", "(n, 4)");
  if (q.ndim() != 2 || q.shape(1) != 4) throw py::value_error("quaternions: expected shape (n, 4), got " + shape_of(q));
  const py::ssize_t n = q.shape(0);
  std::optional<Array<T>> s;
  if (!scales.is_none()) {
    s = transform<T>(scales, "scales", "(n,)");
    if (s->ndim() != 1 || s->shape(0) != n)
      throw py::value_error("scales: expected shape (" + std::to_string(n) + ",), got " + shape_of(*s));
  }
  const int degree = sh_degree(sh_rest);
  const SplatArrays<T> a{in_place<T>(rotations, "rotations", n, 4), in_place<T>(log_scales, "log_scales", n, 3),
                         in_place<T>(sh_rest, "sh_rest", n, splat_sh_rest_count(degree)), degree};
  checked_threads(threads);
  check_outputs_apart({{"rotations", rotations}, {"log_scales", log_scales}, {"sh_rest", sh_rest}});
  const Array<T> turns = apart_from(q, {rotations, log_scales, sh_rest});
  if (s) s = apart_from(*s, {rotations, log_scales, sh_rest});
  const py::gil_scoped_release release;
  rotate_splats<T>(a, std::size_t(n), turns.data(), s ? s->data() : nullptr, threads);
}

template <class T>
void affine_t(const py::object& linear, const py::object& rotations, const py::object& log_scales,
              const py::object& sh_rest, int threads) {
  const Array<T> m = transform<T>(linear, "linear", "(n, 3, 3)");
  if (!((m.ndim() == 3 && m.shape(1) == 3 && m.shape(2) == 3) || (m.ndim() == 2 && m.shape(1) == 9)))
    throw py::value_error("linear: expected shape (n, 3, 3) or (n, 9), got " + shape_of(m));
  const py::ssize_t n = m.shape(0);
  const int degree = sh_degree(sh_rest);
  const SplatArrays<T> a{in_place<T>(rotations, "rotations", n, 4), in_place<T>(log_scales, "log_scales", n, 3),
                         in_place<T>(sh_rest, "sh_rest", n, splat_sh_rest_count(degree)), degree};
  checked_threads(threads);
  check_outputs_apart({{"rotations", rotations}, {"log_scales", log_scales}, {"sh_rest", sh_rest}});
  const Array<T> matrices = apart_from(m, {rotations, log_scales, sh_rest});
  const py::gil_scoped_release release;
  transform_splats_affine<T>(a, std::size_t(n), matrices.data(), threads);
}

}  // namespace

void bind_splats(py::module_& m) {
  m.def(
      "rotate_splats",
      [](const py::object& quaternions, const py::object& scales, const py::object& rotations,
         const py::object& log_scales, const py::object& sh_rest, int threads) {
        if (single(rotations, log_scales, sh_rest))
          return rotate_t<float>(quaternions, scales, rotations, log_scales, sh_rest, threads);
        rotate_t<double>(quaternions, scales, rotations, log_scales, sh_rest, threads);
      },
      py::arg("quaternions"), py::arg("scales") = py::none(), py::kw_only(), py::arg("rotations") = py::none(),
      py::arg("log_scales") = py::none(), py::arg("sh_rest") = py::none(), py::arg("threads") = 1,
      R"(rotate_splats(quaternions, scales=None, *, rotations=None, log_scales=None, sh_rest=None, threads=1)

Turns n Gaussian splats (the 3DGS layout, docs/splats.md) in place by per-splat unit quaternions (n, 4), w x y z,
and grows them by scales (n,) if given (a similarity). rotations (n, 4): rot_0..3, composed q' = q_R q and
normalised; log_scales (n, 3): scale_0..2, offset by log(s); sh_rest (n, 45), (n, 24) or (n, 9) (or (n, 3, k)):
f_rest_* channel-major, bands 1-3 rotated so that the colour seen from R d is the one formerly seen from d. The
arrays updated must be C-contiguous and writeable, float32 or float64 alike, and share no memory (ValueError
naming two that do); None leaves one out. quaternions and scales are read as passed, even where they share
memory with an array updated (copied first). A splat whose transform is exactly the identity keeps every bit. ValueError naming the splat, with nothing written, for NaN
or infinite values, a quaternion that is not of unit length, a scale <= 0, a zero rot_*.)");
  m.def(
      "transform_splats_affine",
      [](const py::object& linear, const py::object& rotations, const py::object& log_scales, const py::object& sh_rest,
         int threads) {
        if (single(rotations, log_scales, sh_rest))
          return affine_t<float>(linear, rotations, log_scales, sh_rest, threads);
        affine_t<double>(linear, rotations, log_scales, sh_rest, threads);
      },
      py::arg("linear"), py::kw_only(), py::arg("rotations") = py::none(), py::arg("log_scales") = py::none(),
      py::arg("sh_rest") = py::none(), py::arg("threads") = 1,
      R"(transform_splats_affine(linear, *, rotations=None, log_scales=None, sh_rest=None, threads=1)

Maps n splats in place by per-splat linear parts M (n, 3, 3) (the affine deformation's frames): the covariance
M Sigma M^T decomposed again into rotations and log_scales (both or neither), its axes matched to the images of
the old ones; sh_rest rotated by M's polar rotation (mirrored for det M < 0). linear is read as passed, even
where it shares memory with an array updated. ValueError as rotate_splats, and for a singular M.)");
}

}  // namespace mlsdeform::python
