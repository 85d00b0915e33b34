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
#include <memory>
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

/// The library's interleaved batch call on H (m, 3, 3) into R, with the library's message for bad input naming
/// the function Python called.
template <class T>
void fit_interleaved(const T* h, T* r, std::size_t m, RotationMethod method, int threads, const CancelCheck& cancel) {
  try {
    fit_rotations_interleaved(h, r, m, method, threads, nullptr, cancel);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    const std::size_t colon = what.find(": ");
    throw std::invalid_argument("fit_rotations" + (colon == std::string::npos ? ": " + what : what.substr(colon)));
  }
}

/// What the binding does before the library's call: H's shape, `out`, the threads; R is the array to return.
template <class T>
py::array_t<T> checked_output(const Array<T>& H, int threads, const py::object& out) {
  if (H.ndim() != 3 || H.shape(1) != 3 || H.shape(2) != 3)
    throw py::value_error("H: expected shape (m, 3, 3), got " + shape_of(H));
  checked_threads(threads);
  return rotations_out<T>(out, H.shape(0));
}

// The per-call work is the library's (its finite check, the fits, the transposes between numpy's layout and
// the lanes', all in its parallel chunks) and, around it, the argument checks and the release of the GIL.
template <class T>
py::array_t<T> fit_rotations_t(Array<T> H, RotationMethod method, int threads, const py::object& out = py::none()) {
  py::array_t<T> R = checked_output(H, threads, out);
  const std::size_t m = static_cast<std::size_t>(H.shape(0));
  // Both are C-contiguous (m, 3, 3) arrays of T here, so `out` either is H (the library fits in place) or
  // overlaps it shifted, where writing a chunk would overwrite the H of a chunk not read yet: then the
  // rotations go to the scratch array below and reach `out` only after the last chunk has read H.
  const bool overlaps = !out.is_none() && R.data() != H.data() && may_share_memory(H, R);
  // Signals are checked between chunks of 2,048 matrices. So that an interrupted call leaves a caller's `out`
  // untouched, the rotations then go to a scratch array, copied into `out` at the end: a fresh buffer's page
  // faults and one more pass, which make a float fit into `out` about 1.5 times as long. So with `out` only a
  // batch of more than about 0.3 s of work is watched (2^22 matrices by the SIMD methods, 2^18 by the scalar
  // ones, which take about 15 times as long each); a shorter one is written straight into `out`, unwatched.
  const bool scalar =
      method == RotationMethod::svd || method == RotationMethod::kanatani || method == RotationMethod::horn_matrix;
  const bool watched = m > 2048 && (out.is_none() || m > (scalar ? std::size_t(1) << 18 : std::size_t(1) << 22));
  const bool scratch = (watched && !out.is_none()) || overlaps;
  const T* h = H.data();
  T* r = R.mutable_data();
  interruptible(watched, [&](const CancelCheck& cancel) {
    if (!scratch) return fit_interleaved(h, r, m, method, threads, cancel);
    const std::unique_ptr<T[]> rotations(new T[9 * m]);  // not zeroed
    fit_interleaved(h, rotations.get(), m, method, threads, cancel);
    std::memcpy(r, rotations.get(), 9 * m * sizeof(T));
  });
  return R;
}

/// Seconds of the library's call alone, on the arrays overhead.py gives fit_rotations: `interleaved`, the very
/// call fit_rotations makes on H and out; else fit_rotations on a 3 x 3 x m copy of H made beforehand (the
/// layout the lanes read, so the difference is the price of numpy's layout).
template <class T>
double time_cpp_fit_rotations(const Array<T>& H, int threads, const py::object& out, bool interleaved) {
  py::array_t<T> R = checked_output(H, threads, out);
  const std::size_t m = static_cast<std::size_t>(H.shape(0));
  const T* h = H.data();
  T* r = R.mutable_data();
  const py::gil_scoped_release release;
  std::vector<T> soa, rsoa;
  if (!interleaved) {
    soa.resize(9 * m);
    rsoa.resize(9 * m);
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t e = 0; e < 9; ++e) soa[e * m + i] = h[9 * i + e];
    // Once untimed, so that the timed call finds the caches as a repeated call does (the copy just written
    // would otherwise be partly in the last-level cache).
    fit_rotations(soa.data(), rsoa.data(), m, RotationMethod::axis_angle, threads);
  }
  const auto t0 = std::chrono::steady_clock::now();
  if (interleaved)
    fit_rotations_interleaved(h, r, m, RotationMethod::axis_angle, threads);
  else
    fit_rotations(soa.data(), rsoa.data(), m, RotationMethod::axis_angle, threads);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool wants_single(const py::object& obj) {
  return py::isinstance<py::array>(obj) && py::reinterpret_borrow<py::array>(obj).dtype().equal(py::dtype::of<float>());
}

py::array fit_rotations_py(const py::object& H, const std::string& method, int threads, const py::object& out) {
  const RotationMethod m = parse_method(method);
  if (wants_single(H)) return fit_rotations_t<float>(Array<float>::ensure(H), m, threads, out);
  const Array<double> a = try_array<double>(H);
  if (!a) throw py::type_error("H: expected an (m, 3, 3) array of real numbers, got " + received(H));
  return fit_rotations_t<double>(a, m, threads, out);
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
of more than 2,048 matrices between chunks of 2,048: KeyboardInterrupt, out untouched (with out=, only batches
of more than 2^22 matrices, 2^18 by the scalar methods).)");
  m.def(
      "_time_cpp_fit_rotations",
      [](const py::object& H, int threads, const py::object& out, bool interleaved) {
        if (wants_single(H)) return time_cpp_fit_rotations<float>(Array<float>::ensure(H), threads, out, interleaved);
        return time_cpp_fit_rotations<double>(Array<double>::ensure(H), threads, out, interleaved);
      },
      py::arg("H"), py::arg("threads") = 1, py::kw_only(), py::arg("out") = py::none(), py::arg("interleaved") = true,
      "Seconds of the library's batched fit alone on H (into out): for python/bench/overhead.py.");
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
