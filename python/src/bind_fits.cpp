// The rotation fits: fit_rotations (batched, in SIMD lanes, in place where asked), fit_rotation (one 3 x 3)
// and fit_points (the weighted rigid or similarity fit of two point sets).
#include "python/src/arrays.hpp"
#include "python/src/bindings.hpp"
#include "python/src/signals.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlsdeform::python {
namespace {

/// (m, 3, 3) -> (m, 3, 3) through the library's 3 x 3 x m structure-of-arrays batch (scratch transposes).
/// `out`: None (a new array) or a C-contiguous, writeable (m, 3, 3) array of T, written in place.
template <class T>
py::array_t<T> rotations_out(const py::object& out, py::ssize_t m) {
  if (out.is_none()) return py::array_t<T>({m, py::ssize_t(3), py::ssize_t(3)});
  if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array");
  const py::array a = py::reinterpret_borrow<py::array>(out);
  if (!a.dtype().equal(py::dtype::of<T>()))
    throw py::type_error(std::string("out: expected dtype ") + (sizeof(T) == 4 ? "float32" : "float64") +
                         " (that of H), got " + std::string(py::str(a.dtype())));
  if (a.ndim() != 3 || a.shape(0) != m || a.shape(1) != 3 || a.shape(2) != 3)
    throw py::value_error("out: expected shape (" + std::to_string(m) + ", 3, 3), got " + shape_of(a));
  if (!(a.flags() & py::array::c_style)) throw py::value_error("out: must be C-contiguous");
  if (!a.writeable()) throw py::value_error("out: is read-only");
  return py::reinterpret_borrow<py::array_t<T>>(out);
}

/// The first non-finite entry of m row-major 3 x 3 matrices (error path only: names the matrix and entry).
template <class T>
[[noreturn]] void throw_non_finite(const T* h, std::size_t m) {
  for (std::size_t i = 0; i < m; ++i)
    for (int e = 0; e < 9; ++e)
      if (!std::isfinite(h[9 * i + e]))
        throw std::invalid_argument("fit_rotations: H[" + std::to_string(i) + ", " + std::to_string(e / 3) + ", " +
                                    std::to_string(e % 3) + "] is NaN or infinite");
  throw std::invalid_argument("fit_rotations: H has a NaN or infinite entry");
}

template <class T>
py::array_t<T> fit_rotations_t(Array<T> H, RotationMethod method, int threads, double* seconds_cpp,
                               const py::object& out = py::none()) {
  if (H.ndim() != 3 || H.shape(1) != 3 || H.shape(2) != 3)
    throw py::value_error("H: expected shape (m, 3, 3), got " + shape_of(H));
  checked_threads(threads);
  const std::size_t m = static_cast<std::size_t>(H.shape(0));
  py::array_t<T> R = rotations_out<T>(out, H.shape(0));
  // Both are C-contiguous (m, 3, 3) arrays of T here, so `out` either is H (each block below is copied out
  // of H before its rotations are written back over the same rows: in place works) or overlaps it shifted,
  // where writing block b would overwrite the H of a block not read yet: then the rotations go to the scratch
  // array below and reach `out` only after the last block has read H.
  const bool overlaps = !out.is_none() && R.data() != H.data() && may_share_memory(H, R);
  const T* h = H.data();
  T* r = R.mutable_data();
  SignalWatch watch;
  try {
    py::gil_scoped_release release;
    if (seconds_cpp) {  // the reference figure: the batched call alone on data already in its layout
      std::vector<T> soa(9 * m), rsoa(9 * m);
      for (std::size_t i = 0; i < m; ++i)
        for (std::size_t e = 0; e < 9; ++e) soa[e * m + i] = h[9 * i + e];
      const auto t0 = std::chrono::steady_clock::now();
      fit_rotations(soa.data(), rsoa.data(), m, method, threads);
      *seconds_cpp = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      return R;
    }
    // Blocks small enough that the transposed copies stay in cache (2 x 9 x 2048 values: 147 KiB in float,
    // 295 KiB in double), larger when the library spreads a block over threads.
    const std::size_t block = threads == 1 ? 2048 : 32768;
    std::vector<T> soa(9 * std::min(block, m)), rsoa(soa.size());
    // Signals are checked between blocks. So that an interrupted call leaves a caller's `out` untouched, the
    // rotations then go to a scratch array, copied into `out` at the end: a fresh buffer's page faults and one
    // more pass, which make a float fit into `out` about 1.5 times as long. So with `out` only a batch of more
    // than about 0.3 s of work is watched (2^22 matrices by the SIMD methods, 2^18 by the scalar ones, which
    // take about 15 times as long each); a shorter one is written straight into `out`, unwatched.
    const bool scalar =
        method == RotationMethod::svd || method == RotationMethod::kanatani || method == RotationMethod::horn_matrix;
    const bool watched = m > block && (out.is_none() || m > (scalar ? std::size_t(1) << 18 : std::size_t(1) << 22));
    const CancelCheck cancel = watched ? watch.check() : CancelCheck();
    const std::unique_ptr<T[]> scratch((watched && !out.is_none()) || overlaps ? new T[9 * m] : nullptr);  // not zeroed
    T* dest = scratch ? scratch.get() : r;
    // A caller's `out` must stay untouched on error: all of H is checked before the first block is written
    // (the library checks each block again). On the exponent bits, so that it vectorises.
    if (!out.is_none()) {
      using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
      constexpr Bits exponent = sizeof(T) == 4 ? Bits(0x7f800000u) : Bits(0x7ff0000000000000ull);
      Bits non_finite = 0;
      for (std::size_t i = 0; i < 9 * m; ++i) {
        Bits b;
        std::memcpy(&b, h + i, sizeof b);
        non_finite |= Bits((b & exponent) == exponent);
      }
      if (non_finite) throw_non_finite(h, m);
    }
    for (std::size_t first = 0; first < m; first += block) {
      if (cancel && cancel()) throw Cancelled();
      const std::size_t b = std::min(block, m - first);
      const T* hb = h + 9 * first;
      for (std::size_t i = 0; i < b; ++i)
        for (std::size_t e = 0; e < 9; ++e) soa[e * b + i] = hb[9 * i + e];
      try {
        fit_rotations(soa.data(), rsoa.data(), b, method, threads);
      } catch (const std::invalid_argument&) {
        throw_non_finite(h, m);  // name the matrix by its index in H, not in the block
      }
      T* rb = dest + 9 * first;
      for (std::size_t i = 0; i < b; ++i)
        for (std::size_t e = 0; e < 9; ++e) rb[9 * i + e] = rsoa[e * b + i];
    }
    if (dest != r) std::memcpy(r, dest, 9 * m * sizeof(T));
  } catch (...) {  // as in interruptible()
    watch.raise_kept();
    throw;
  }
  watch.raise_kept();
  return R;
}

bool wants_single(const py::object& obj) {
  return py::isinstance<py::array>(obj) && py::reinterpret_borrow<py::array>(obj).dtype().equal(py::dtype::of<float>());
}

py::array fit_rotations_py(const py::object& H, const std::string& method, int threads, const py::object& out) {
  const RotationMethod m = parse_method(method);
  if (wants_single(H)) return fit_rotations_t<float>(Array<float>::ensure(H), m, threads, nullptr, out);
  const Array<double> a = try_array<double>(H);
  if (!a) throw py::type_error("H: expected an (m, 3, 3) array of real numbers, got " + received(H));
  return fit_rotations_t<double>(a, m, threads, nullptr, out);
}

template <class T>
py::array fit_rotation_t(const Array<T>& H, RotationMethod method) {
  if (H.ndim() != 2 || H.shape(0) != 3 || H.shape(1) != 3)
    throw py::value_error("H: expected shape (3, 3), got " + shape_of(H));
  const Matrix3<T> R = fit_rotation(Eigen::Map<const Eigen::Matrix<T, 3, 3, Eigen::RowMajor>>(H.data()), method);
  py::array_t<T> out({py::ssize_t(3), py::ssize_t(3)});
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out.mutable_data()[3 * i + j] = R(i, j);
  return out;
}

template <class T>
py::tuple fit_points_t(const py::object& P, const py::object& Q, const py::object& w, Transform transform,
                       RotationMethod method) {
  const Points<T> p = to_points(as_n3<T>(P, "P")), q = to_points(as_n3<T>(Q, "Q"));
  Eigen::Matrix<T, Eigen::Dynamic, 1> weights;
  if (!w.is_none()) {
    const Array<T> a = try_array<T>(w);
    if (!a || a.ndim() != 1) throw py::value_error("w: expected a 1-D array of weights");
    weights = Eigen::Map<const Eigen::Matrix<T, Eigen::Dynamic, 1>>(a.data(), a.shape(0));
  }
  if (transform == Transform::affine) throw py::value_error("transform: fit_points supports 'rigid' and 'similarity'");
  SimilarityTransform<T> f;
  try {
    const py::gil_scoped_release release;  // p, q and the weights are copies: nothing of Python's is read
    f = transform == Transform::rigid ? fit_rigid<T>(p, q, weights, method) : fit_similarity<T>(p, q, weights, method);
  } catch (const std::invalid_argument& e) {  // the GIL is held again here
    // The library names its own function (fit_rigid: ..., fit_similarity: ...); name the one called here.
    const std::string what = e.what();
    const std::size_t colon = what.find(": ");
    throw py::value_error("fit_points" + (colon == std::string::npos ? ": " + what : what.substr(colon)));
  }
  py::array_t<T> R({py::ssize_t(3), py::ssize_t(3)}), t(py::ssize_t(3));
  for (int i = 0; i < 3; ++i) {
    t.mutable_data()[i] = f.translation[i];
    for (int j = 0; j < 3; ++j) R.mutable_data()[3 * i + j] = f.rotation(i, j);
  }
  if (transform == Transform::rigid) return py::make_tuple(R, t);
  return py::make_tuple(R, t, f.scale);
}

}  // namespace

void bind_fits(py::module_& m) {
  m.def("fit_rotations", &fit_rotations_py, py::arg("H"), py::kw_only(), py::arg("method") = "axis_angle",
        py::arg("threads") = 1, py::arg("out") = py::none(),
        R"(fit_rotations(H, *, method="axis_angle", threads=1, out=None) -> (m, 3, 3) array

Batched rotation fit in SIMD lanes: for each correlation matrix H[i] = sum_j w_j qhat_j phat_j^T, the
proper rotation R[i] maximising trace(R^T H). float32 in gives float32 out, anything else float64.
threads: 1 = the calling thread, 0 = all cores. out: a C-contiguous (m, 3, 3) array of H's dtype to write
into (returned); it may be H itself or overlap H (the rotations then reach out after all of H is read). The
GIL is released. ValueError naming the first NaN or infinite entry, with nothing written. Ctrl-C stops a batch
of more than one block (2,048 matrices, 32,768 with threads): KeyboardInterrupt, out untouched (with out=, only
batches of more than 2^22 matrices, 2^18 by the scalar methods).)");
  m.def(
      "_time_cpp_fit_rotations",
      [](const py::object& H, int threads) {
        double seconds = 0;
        if (wants_single(H))
          fit_rotations_t<float>(Array<float>::ensure(H), RotationMethod::axis_angle, threads, &seconds);
        else
          fit_rotations_t<double>(Array<double>::ensure(H), RotationMethod::axis_angle, threads, &seconds);
        return seconds;
      },
      py::arg("H"), py::arg("threads") = 1);
  m.def(
      "fit_rotation",
      [](const py::object& H, const std::string& method) -> py::array {
        const RotationMethod mth = parse_method(method);
        if (wants_single(H)) return fit_rotation_t<float>(Array<float>::ensure(H), mth);
        const Array<double> a = try_array<double>(H);
        if (!a) throw py::type_error("H: expected a (3, 3) array of real numbers, got " + received(H));
        return fit_rotation_t<double>(a, mth);
      },
      py::arg("H"), py::kw_only(), py::arg("method") = "axis_angle",
      "fit_rotation(H, *, method='axis_angle') -> (3, 3): the proper rotation maximising trace(R^T H).");
  m.def(
      "fit_points",
      [](const py::object& P, const py::object& Q, const py::object& w, const std::string& transform,
         const std::string& method) {
        const Transform t = parse_transform(transform);
        const RotationMethod mth = parse_method(method);
        if (wants_single(P)) return fit_points_t<float>(P, Q, w, t, mth);
        return fit_points_t<double>(P, Q, w, t, mth);
      },
      py::arg("P"), py::arg("Q"), py::arg("w") = py::none(), py::kw_only(), py::arg("transform") = "rigid",
      py::arg("method") = "axis_angle",
      R"(fit_points(P, Q, w=None, *, transform="rigid", method="axis_angle") -> (R, t) or (R, t, s)

The transform x -> s R x + t minimising sum_i w_i |s R P_i + t - Q_i|^2 (paper eqs. 1-4; Sec. 6.1 for the
scale): "rigid" returns (R, t), "similarity" (R, t, s). w: n non-negative weights (None: all ones).)");
}

}  // namespace mlsdeform::python
