// The session behind mlsdeform.Deformer: a Deformer<float> or Deformer<double>, chosen by the dtype of the
// rest vertices; numpy in, numpy out, the per-frame path writing into the caller's array with no copy.
#pragma once

#include "python/src/arrays.hpp"
#include "python/src/signals.hpp"

#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <chrono>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace mlsdeform::python {

/// Deformer.deform's frame outputs (FramesOut): None, or the caller's preallocated arrays.
struct FrameArgs {
  py::object quaternions, rotations, scales, linear;
};

/// Handles from the optional points array and (a, b) segment tuple, in precision T.
template <class T>
Handles<T> make_handles(const py::object& points, const py::object& segments) {
  Handles<T> h;
  h.points.resize(0, 3);
  h.segment_a.resize(0, 3);
  h.segment_b.resize(0, 3);
  if (!points.is_none()) h.points = to_points(as_n3<T>(points, "points"));
  if (!segments.is_none()) {
    py::sequence seq;
    try {
      seq = segments.cast<py::sequence>();
    } catch (const py::cast_error&) {
      throw py::type_error("segments: expected a pair (A, B) of (s, 3) arrays of end points");
    }
    if (py::len(seq) != 2) throw py::value_error("segments: expected a pair (A, B) of (s, 3) arrays of end points");
    h.segment_a = to_points(as_n3<T>(seq[0], "segments[0]"));
    h.segment_b = to_points(as_n3<T>(seq[1], "segments[1]"));
    if (h.segment_a.rows() != h.segment_b.rows())
      throw py::value_error("segments: A has " + std::to_string(h.segment_a.rows()) + " rows but B has " +
                            std::to_string(h.segment_b.rows()));
  }
  return h;
}

/// The session's options from Deformer's keyword arguments (also those of mlsdeform.files.DeformJob), each
/// checked; the region is the caller's.
inline Options parse_options(const std::string& transform, double exponent, const std::string& method,
                             const std::string& segment_weight, int threads, const std::string& weight_storage,
                             const std::string& backend, std::size_t budget_bytes, int arap_iterations,
                             const std::string& centroids, const std::string& arap_acceleration, bool arap_warm_start,
                             bool affine_frames) {
  Options o;
  o.transform = parse_transform(transform);
  o.weight_exponent = exponent;
  o.method = parse_method(method);
  o.segment_weight = parse_enum<SegmentWeight>(
      segment_weight, "segment_weight",
      {{"paper_constant", SegmentWeight::paper_constant}, {"exact_integral", SegmentWeight::exact_integral}});
  o.threads = checked_threads(threads);
  o.weight_storage = parse_enum<WeightStorage>(weight_storage, "weight_storage",
                                               {{"automatic", WeightStorage::automatic},
                                                {"precomputed", WeightStorage::precomputed},
                                                {"on_the_fly", WeightStorage::on_the_fly},
                                                {"precomputed_weights", WeightStorage::precomputed_weights}});
  o.isa = parse_enum<std::optional<Isa>>(backend, "backend", {{"simd", std::nullopt}, {"scalar", Isa::scalar}});
  o.precompute_budget_bytes = budget_bytes;
  o.arap_iterations = arap_iterations;
  o.arap_acceleration =
      parse_enum<ArapAcceleration>(arap_acceleration, "arap_acceleration",
                                   {{"none", ArapAcceleration::none}, {"anderson", ArapAcceleration::anderson}});
  o.arap_warm_start = arap_warm_start;
  o.affine_frames = affine_frames;
  o.centroids = parse_enum<Centroids>(centroids, "centroids", {{"mls", Centroids::mls}, {"rbf", Centroids::rbf}});
  return o;
}

/// A session in float or double, chosen by the dtype of the rest vertices.
class PyDeformer {
  // Exactly one is set, by the constructor.
  std::unique_ptr<Deformer<float>> single_;
  std::unique_ptr<Deformer<double>> double_;

  template <class T>
  Deformer<T>& get() const {
    if constexpr (std::is_same_v<T, float>)
      return *single_;
    else
      return *double_;
  }
  template <class F>
  decltype(auto) visit(F&& f) const {
    return single_ ? f(*single_) : f(*double_);
  }

 public:
  PyDeformer(const py::object& vertices, const py::object& points, const py::object& segments,
             const std::string& transform, double exponent, const std::string& method,
             const std::string& segment_weight, int threads, const std::string& weight_storage,
             const std::string& backend, std::size_t budget_bytes, const py::object& dtype, const py::object& faces,
             int arap_iterations, const std::string& centroids, const py::object& region,
             const std::string& arap_acceleration, bool arap_warm_start, bool affine_frames) {
    Options o =
        parse_options(transform, exponent, method, segment_weight, threads, weight_storage, backend, budget_bytes,
                      arap_iterations, centroids, arap_acceleration, arap_warm_start, affine_frames);
    if (!region.is_none()) {
      o.region = to_indices(region, "region");
      if (o.region.empty()) throw py::value_error("region: no vertices (pass None to deform the whole model)");
    }
    bool single = false;
    if (!dtype.is_none()) {
      const py::dtype dt = py::dtype::from_args(dtype);
      if (dt.is(py::dtype::of<float>()) || dt.equal(py::dtype::of<float>()))
        single = true;
      else if (!dt.equal(py::dtype::of<double>()))
        throw py::type_error("dtype: expected float32 or float64");
    } else if (py::isinstance<py::array>(vertices)) {
      single = py::reinterpret_borrow<py::array>(vertices).dtype().equal(py::dtype::of<float>());
    }
    if (points.is_none() && segments.is_none())
      throw py::value_error("Deformer: no handles (give points=..., segments=(A, B), or both)");
    const Triangles triangles = to_triangles(faces);
    if (single)
      make<float>(vertices, points, segments, triangles, o);
    else
      make<double>(vertices, points, segments, triangles, o);
  }

  bool single() const { return single_ != nullptr; }
  py::dtype dtype() const { return single() ? py::dtype::of<float>() : py::dtype::of<double>(); }
  Eigen::Index vertex_count() const {
    return visit([](const auto& d) { return d.vertex_count(); });
  }

  py::array deform(const py::object& points, const py::object& segments, const py::object& out,
                   const py::object& quaternions, const py::object& rotations, const py::object& scales,
                   const py::object& linear) const {
    const FrameArgs frames{quaternions, rotations, scales, linear};
    return single() ? run<float>(points, segments, out, frames) : run<double>(points, segments, out, frames);
  }

  void set_point_target(Eigen::Index i, const py::object& q) {
    visit([&](auto& d) { d.set_point_target(i, vector3<typename Scalar<decltype(d)>::type>(q, "target")); });
  }
  void set_segment_target(Eigen::Index i, const py::object& a, const py::object& b) {
    visit([&](auto& d) {
      using T = typename Scalar<decltype(d)>::type;
      d.set_segment_target(i, vector3<T>(a, "a"), vector3<T>(b, "b"));
    });
  }
  void transform_handles(const py::object& points, const py::object& segments, const py::object& rotation,
                         const py::object& translation, const py::object& pivot) {
    const std::vector<Eigen::Index> pi = points.is_none() ? std::vector<Eigen::Index>() : to_indices(points, "points");
    const std::vector<Eigen::Index> si =
        segments.is_none() ? std::vector<Eigen::Index>() : to_indices(segments, "segments");
    visit([&](auto& d) {
      using T = typename Scalar<decltype(d)>::type;
      const Matrix3<T> R = rotation.is_none() ? Matrix3<T>::Identity() : matrix3<T>(rotation, "rotation");
      const Vector3<T> t = translation.is_none() ? Vector3<T>::Zero() : vector3<T>(translation, "translation");
      const Vector3<T> c = pivot.is_none() ? Vector3<T>::Zero() : vector3<T>(pivot, "pivot");
      d.transform_handles(pi, si, R, t, c);
    });
  }
  py::dict targets() const {
    return visit([](const auto& d) {
      const auto& h = d.targets();
      py::dict r;
      r["points"] = from_points(h.points);
      r["segments"] = py::make_tuple(from_points(h.segment_a), from_points(h.segment_b));
      return r;
    });
  }
  std::size_t memory_bytes() const {
    return visit([](const auto& d) { return d.memory_bytes(); });
  }
  bool uses_precomputed_weights() const {
    return visit([](const auto& d) { return d.uses_precomputed_weights(); });
  }
  Eigen::Index point_count() const {
    return visit([](const auto& d) { return d.targets().point_count(); });
  }
  Eigen::Index segment_count() const {
    return visit([](const auto& d) { return d.targets().segment_count(); });
  }

  /// Seconds per frame of `reps` calls of the C++ deform into `out` with the given handles, timed inside
  /// C++ (no Python in the loop): the reference of the overhead benchmark (python/bench/overhead.py).
  double time_cpp_deform(const py::object& points, const py::object& segments, const py::object& out, int reps) {
    return single() ? time_cpp<float>(points, segments, out, reps) : time_cpp<double>(points, segments, out, reps);
  }

 private:
  template <class D>
  struct Scalar;
  template <class T>
  struct Scalar<Deformer<T>&> {
    using type = T;
  };

  template <class T>
  static Vector3<T> vector3(const py::object& obj, const char* name) {
    const Array<T> a = try_array<T>(obj);
    if (!a) throw py::type_error(std::string(name) + ": expected 3 real numbers, got " + received(obj));
    if (a.size() != 3) throw py::value_error(std::string(name) + ": expected 3 numbers, got shape " + shape_of(a));
    return Vector3<T>(a.data()[0], a.data()[1], a.data()[2]);
  }

  template <class T>
  static Matrix3<T> matrix3(const py::object& obj, const char* name) {
    const Array<T> a = try_array<T>(obj);
    if (!a) throw py::type_error(std::string(name) + ": expected a 3 x 3 array of real numbers, got " + received(obj));
    if (a.ndim() != 2 || a.shape(0) != 3 || a.shape(1) != 3)
      throw py::value_error(std::string(name) + ": expected shape (3, 3), got " + shape_of(a));
    Matrix3<T> m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m(i, j) = a.data()[3 * i + j];
    return m;
  }

  /// A 1-D sequence of integer indices (region=, transform_handles): range checks are the library's.
  static std::vector<Eigen::Index> to_indices(const py::object& obj, const char* name) {
    const auto ints = integer_indices(obj, name, "a 1-D sequence of integer indices");
    if (ints.ndim() != 1)
      throw py::value_error(std::string(name) + ": expected a 1-D sequence of integer indices, got shape " +
                            shape_of(ints));
    return std::vector<Eigen::Index>(ints.data(), ints.data() + ints.size());
  }

  /// faces: None or an (m, 3) array of integer vertex indices.
  static Triangles to_triangles(const py::object& faces) {
    if (faces.is_none()) return Triangles();
    const auto a = integer_indices(faces, "faces", "an (m, 3) array of integer vertex indices");
    if (a.ndim() != 2 || a.shape(1) != 3)
      throw py::value_error("faces: expected an (m, 3) array of vertex indices, got shape " + shape_of(a));
    Triangles t(a.shape(0), 3);
    const long long* f = a.data();
    for (Eigen::Index i = 0; i < t.size(); ++i) {
      if (f[i] < 0 || f[i] > std::numeric_limits<int>::max())
        throw py::value_error("faces: vertex index " + std::to_string(f[i]) + " out of range");
      t.data()[i] = int(f[i]);
    }
    return t;
  }

  template <class T>
  void make(const py::object& vertices, const py::object& points, const py::object& segments,
            const Triangles& triangles, const Options& o) {
    const Points<T> v = to_points(as_n3<T>(vertices, "vertices"));
    const Handles<T> h = make_handles<T>(points, segments);
    std::optional<Deformer<T>> d;
    interruptible(true, [&](const CancelCheck& cancel) { d.emplace(v, triangles, h, o, cancel); });
    if constexpr (std::is_same_v<T, float>)
      single_ = std::make_unique<Deformer<float>>(std::move(*d));
    else
      double_ = std::make_unique<Deformer<double>>(std::move(*d));
  }

  /// The moved handles: the given arrays, the session's current targets for the kinds not given.
  template <class T>
  Handles<T> moved(const py::object& points, const py::object& segments) const {
    const Deformer<T>& d = get<T>();
    Handles<T> h = make_handles<T>(points, segments);
    if (points.is_none()) h.points = d.targets().points;
    if (segments.is_none()) {
      h.segment_a = d.targets().segment_a;
      h.segment_b = d.targets().segment_b;
    }
    return h;
  }

  /// `out`: None (a new array), or a C-contiguous, writeable (n, 3) array of the session's dtype (no copy).
  template <class T>
  py::array_t<T> output(const py::object& out) const {
    const Eigen::Index n = get<T>().vertex_count();
    if (out.is_none()) return py::array_t<T>({n, Eigen::Index(3)});
    if (!py::isinstance<py::array>(out)) throw py::type_error("out: expected a numpy array");
    const py::array a = py::reinterpret_borrow<py::array>(out);
    if (!a.dtype().equal(py::dtype::of<T>()))
      throw py::type_error(std::string("out: expected dtype ") + (sizeof(T) == 4 ? "float32" : "float64") +
                           " (the session's), got " + std::string(py::str(a.dtype())));
    if (a.ndim() != 2 || a.shape(0) != n || a.shape(1) != 3)
      throw py::value_error("out: expected shape (" + std::to_string(n) + ", 3), got " + shape_of(a));
    if (!(a.flags() & py::array::c_style)) throw py::value_error("out: must be C-contiguous");
    if (!a.writeable()) throw py::value_error("out: is read-only");
    return py::reinterpret_borrow<py::array_t<T>>(out);
  }

  /// A frame output (FrameArgs): None (not wanted), or a C-contiguous, writeable array of the session's dtype
  /// of shape (n,) + `tail` (no copy: the library writes into it).
  template <class T>
  std::span<T> frame_output(const py::object& obj, const char* name, std::initializer_list<py::ssize_t> tail) const {
    if (obj.is_none()) return {};
    const py::ssize_t n = get<T>().vertex_count();
    std::string want = "(" + std::to_string(n) + (tail.size() == 0 ? "," : "");
    for (const py::ssize_t t : tail) want += ", " + std::to_string(t);
    want += ")";
    if (!py::isinstance<py::array>(obj)) throw py::type_error(std::string(name) + ": expected a numpy array");
    py::array a = py::reinterpret_borrow<py::array>(obj);
    if (!a.dtype().equal(py::dtype::of<T>()))
      throw py::type_error(std::string(name) + ": expected dtype " + (sizeof(T) == 4 ? "float32" : "float64") +
                           " (the session's), got " + std::string(py::str(a.dtype())));
    bool shape_ok = a.ndim() == py::ssize_t(1 + tail.size()) && a.shape(0) == n;
    py::ssize_t k = 1, size = n;
    for (const py::ssize_t t : tail) shape_ok = shape_ok && a.shape(k++) == t, size *= t;
    if (!shape_ok) throw py::value_error(std::string(name) + ": expected shape " + want + ", got " + shape_of(a));
    if (!(a.flags() & py::array::c_style)) throw py::value_error(std::string(name) + ": must be C-contiguous");
    if (!a.writeable()) throw py::value_error(std::string(name) + ": is read-only");
    return {static_cast<T*>(a.mutable_data()), std::size_t(size)};
  }

  template <class T>
  py::array run(const py::object& points, const py::object& segments, const py::object& out,
                const FrameArgs& fa) const {
    const Handles<T> h = moved<T>(points, segments);
    py::array_t<T> result = output<T>(out);
    const FramesOut<T> frames{frame_output<T>(fa.quaternions, "quaternions", {4}),
                              frame_output<T>(fa.rotations, "rotations", {3, 3}),
                              frame_output<T>(fa.scales, "scales", {}), frame_output<T>(fa.linear, "linear", {3, 3})};
    // The handles are copies (moved): an output may share memory with them, but not with another output.
    check_outputs_apart({{"out", out},
                         {"quaternions", fa.quaternions},
                         {"rotations", fa.rotations},
                         {"scales", fa.scales},
                         {"linear", fa.linear}});
    const Deformer<T>& d = get<T>();
    T* data = result.mutable_data();
    // Watched: ARAP frames (the library checks between iterations, `out` untouched when stopped) and plain
    // frames of at least 2^24 vertex-handle pairs (about 20 ms and more; the library checks between chunks of
    // its MLS pass). A plain frame writes its output directly, so where the caller gave `out` a watched one
    // deforms into a new array and copies it over only when it has finished: `out` stays untouched when
    // Ctrl-C stops it.
    const std::size_t n = static_cast<std::size_t>(d.vertex_count());
    const std::size_t k = static_cast<std::size_t>(h.point_count() + 2 * h.segment_count());
    const bool arap = d.options().arap_iterations > 0, long_frame = n * k >= (std::size_t(1) << 24);
    const bool scratch = !arap && long_frame && !out.is_none();
    py::array_t<T> work = scratch ? py::array_t<T>({d.vertex_count(), Eigen::Index(3)}) : result;
    T* target = work.mutable_data();
    interruptible(arap || long_frame, [&](const CancelCheck& cancel) {
      d.deform(h, InterleavedView<T>(target, d.vertex_count(), 3), frames, cancel);
      if (scratch) std::memcpy(data, target, sizeof(T) * 3 * n);
    });
    return result;
  }

  template <class T>
  double time_cpp(const py::object& points, const py::object& segments, const py::object& out, int reps) {
    const Handles<T> h = moved<T>(points, segments);
    py::array_t<T> result = output<T>(out);
    const Deformer<T>& d = get<T>();
    T* data = result.mutable_data();
    py::gil_scoped_release release;
    const auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < reps; ++r) d.deform(h, InterleavedView<T>(data, d.vertex_count(), 3));
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
  }
};

}  // namespace mlsdeform::python
