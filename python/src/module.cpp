// The Python binding of mlsdeform (pybind11): numpy in, numpy out. The per-frame path writes straight into
// the caller's C-contiguous (n, 3) array through the library's interleaved output (no copy of the vertices);
// the GIL is released while the library works. Errors keep the library's message: std::invalid_argument ->
// ValueError, std::out_of_range -> IndexError (pybind11's own translations); shape and dtype problems of an
// argument raise ValueError / TypeError naming the argument and what was received. Long calls (a session's
// set-up, ARAP frames, large batches of fits) check for signals while they work (SignalWatch): Ctrl-C raises
// KeyboardInterrupt promptly, leaving outputs untouched.
#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

namespace py = pybind11;
using namespace mlsdeform;

namespace {

template <class T>
using Array = py::array_t<T, py::array::c_style | py::array::forcecast>;

/// Python's main thread (threading.main_thread().ident, read at import): the only one on which Python runs
/// signal handlers.
unsigned long g_main_thread = 0;

/// Signals during a long call that runs with the GIL released. Python runs signal handlers only on its main
/// thread and with the GIL, so the library's cancellation check (mlsdeform::CancelCheck, asked between blocks
/// from any of its threads) does this: on the calling thread, if it is Python's main thread, at most once per
/// kInterval it takes the GIL and calls PyErr_CheckSignals, which runs the handlers; if one raised
/// (KeyboardInterrupt for SIGINT), the exception is kept and every later check, on any thread, says stop.
/// Other threads and the times in between cost one relaxed atomic load (and a clock read). The library then
/// throws mlsdeform::Cancelled having changed nothing, and raise_kept() raises the handler's exception.
/// A signal that arrives after the last check is handled by Python when the call returns, as usual.
class SignalWatch {
 public:
  static constexpr std::chrono::milliseconds kInterval{50};

  SignalWatch()
      : caller_(std::this_thread::get_id()),
        main_(PyThread_get_thread_ident() == g_main_thread),
        next_(std::chrono::steady_clock::now() + kInterval) {}
  SignalWatch(const SignalWatch&) = delete;
  SignalWatch& operator=(const SignalWatch&) = delete;
  ~SignalWatch() {  // destroyed with the GIL held (created with it, outside the released scope)
    Py_XDECREF(type_);
    Py_XDECREF(value_);
    Py_XDECREF(trace_);
  }

  /// The check to hand to the library; valid while *this lives.
  CancelCheck check() {
    if (!main_) return {};  // no signal handler can run on this thread: nothing to check
    return [this] { return poll(); };
  }

  /// With the GIL held, after the call: raises the handler's exception if one was kept.
  void raise_kept() {
    if (!stop_.load(std::memory_order_relaxed)) return;
    PyErr_Restore(type_, value_, trace_);
    type_ = value_ = trace_ = nullptr;
    throw py::error_already_set();
  }

 private:
  bool poll() {
    if (stop_.load(std::memory_order_relaxed)) return true;
    if (std::this_thread::get_id() != caller_) return false;
    const auto now = std::chrono::steady_clock::now();
    if (now < next_) return false;
    next_ = now + kInterval;
    const py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return false;
    PyErr_Fetch(&type_, &value_, &trace_);
    stop_.store(true, std::memory_order_relaxed);
    return true;
  }

  std::thread::id caller_;
  bool main_;
  std::chrono::steady_clock::time_point next_;  ///< touched by the calling thread only
  std::atomic<bool> stop_{false};
  PyObject *type_ = nullptr, *value_ = nullptr, *trace_ = nullptr;
};

/// Runs f(check) with the GIL released and a SignalWatch's check (or an empty one when `watch` is false);
/// a call the watch stopped raises the signal handler's exception (KeyboardInterrupt).
template <class F>
void interruptible(bool watch, F&& f) {
  SignalWatch w;
  try {
    const py::gil_scoped_release release;
    f(watch ? w.check() : CancelCheck());
  } catch (...) {  // Cancelled, or another error while a handler had raised: the handler's exception wins
    w.raise_kept();
    throw;
  }
  w.raise_kept();  // stopped in the last block without a check after it: the signal still counts
}

std::string shape_of(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// obj as a C-contiguous array of T (converted, copied only if it is not one already), or a null array with
/// Python's error indicator cleared where it cannot be converted: the caller raises its own error. Complex
/// numbers are refused (numpy's cast would drop the imaginary part with no more than a warning), and so are
/// dates and durations (their raw counts are no coordinates).
template <class T>
Array<T> try_array(const py::handle& obj) {
  // ensure() gives a null array, with the error indicator cleared, where numpy cannot convert.
  const py::array any = py::array::ensure(obj);
  const char kind = any ? any.dtype().kind() : 'c';
  if (kind == 'c' || kind == 'm' || kind == 'M') return py::reinterpret_steal<Array<T>>(py::handle());
  return Array<T>::ensure(any);
}

/// What a refused argument was, for the message: its dtype if it is an array, else its type.
std::string received(const py::handle& obj) {
  if (py::isinstance<py::array>(obj))
    return "an array of dtype " + std::string(py::str(py::reinterpret_borrow<py::array>(obj).dtype()));
  return std::string(py::str(py::type::of(obj).attr("__name__")));
}

/// An (n, 3) array of T from any array-like.
template <class T>
Array<T> as_n3(const py::handle& obj, const char* name) {
  const Array<T> a = try_array<T>(obj);
  if (!a) {
    throw py::type_error(std::string(name) + ": expected an (n, 3) array of real numbers, got " + received(obj));
  }
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(name) + ": expected shape (n, 3), got " + shape_of(a));
  return a;
}

template <class T>
Points<T> to_points(const Array<T>& a) {
  Points<T> p(a.shape(0), 3);
  const T* d = a.data();
  for (py::ssize_t i = 0; i < a.shape(0); ++i)
    for (int c = 0; c < 3; ++c) p(i, c) = d[3 * i + c];
  return p;
}

template <class T>
py::array_t<T> from_points(const Points<T>& p) {
  py::array_t<T> a({p.rows(), Eigen::Index(3)});
  T* d = a.mutable_data();
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int c = 0; c < 3; ++c) d[3 * i + c] = p(i, c);
  return a;
}

/// The bytes [first, last) that an array's elements span, whatever its strides (negative, zero): the bounds
/// numpy's may_share_memory compares. An empty array spans nothing.
std::pair<std::uintptr_t, std::uintptr_t> byte_extent(const py::array& a) {
  std::uintptr_t first = reinterpret_cast<std::uintptr_t>(a.data()), last = first;
  if (a.size() == 0) return {first, first};
  for (py::ssize_t d = 0; d < a.ndim(); ++d) {
    const py::ssize_t step = (a.shape(d) - 1) * a.strides(d);
    if (step < 0)
      first -= std::uintptr_t(-step);
    else
      last += std::uintptr_t(step);
  }
  return {first, last + std::uintptr_t(a.itemsize())};
}

/// Whether two arrays' memory bounds intersect (numpy's may_share_memory): conservative for interleaved
/// strided views, exact for the C-contiguous arrays the kernels read and write.
bool may_share_memory(const py::array& a, const py::array& b) {
  const auto [a0, a1] = byte_extent(a);
  const auto [b0, b1] = byte_extent(b);
  return a0 < b1 && b0 < a1;
}

/// `threads` of every call that takes one, checked in one place so that the session and the batched fit
/// refuse the same values with the same message (1 = the calling thread, 0 = all cores).
int checked_threads(int threads) {
  if (threads < 0)
    throw py::value_error("threads: expected 0 (all cores) or a positive number of threads, got " +
                          std::to_string(threads));
  return threads;
}

/// Integer indices (faces, region, handle groups) from any array-like, as a C-contiguous int64 array: integer
/// arrays as they are; float arrays (a mesh read as floats) only where every value is an integer, converted
/// exactly. A fractional, non-finite or too large value is a ValueError naming the argument and the value,
/// never truncated; any other dtype (bool, str, object) is a TypeError. Range checks are the caller's.
py::array_t<long long> integer_indices(const py::object& obj, const char* name, const char* expected) {
  using Int64 = py::array_t<long long, py::array::c_style | py::array::forcecast>;
  py::array a;
  try {
    a = py::array::ensure(obj);
  } catch (const py::error_already_set&) {
  }
  if (!a) {
    PyErr_Clear();
    throw py::type_error(std::string(name) + ": expected " + expected);
  }
  const char kind = a.dtype().kind();
  if (a.size() == 0 || kind == 'i') return Int64::ensure(a);
  if (kind == 'u') {
    const auto u = py::array_t<unsigned long long, py::array::c_style | py::array::forcecast>::ensure(a);
    for (py::ssize_t i = 0; i < u.size(); ++i)
      if (u.data()[i] > static_cast<unsigned long long>(std::numeric_limits<long long>::max()))
        throw py::value_error(std::string(name) + ": index " + std::to_string(u.data()[i]) + " is too large");
    return Int64::ensure(a);
  }
  if (kind != 'f')
    throw py::type_error(std::string(name) + ": expected " + expected + ", got dtype " +
                         std::string(py::str(a.dtype())) + (kind == 'b' ? " (for a mask: np.flatnonzero(mask))" : ""));
  const auto f = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  Int64 r(std::vector<py::ssize_t>(f.shape(), f.shape() + f.ndim()));
  // 2^63 is a double; every integral double in [-2^63, 2^63) converts to int64 exactly.
  constexpr double limit = 9223372036854775808.0;
  for (py::ssize_t i = 0; i < f.size(); ++i) {
    const double x = f.data()[i];
    if (!(std::isfinite(x) && x == std::trunc(x)))
      throw py::value_error(std::string(name) + ": expected " + expected + ", found " +
                            std::string(py::repr(py::float_(x))) + " (entry " + std::to_string(i) + ")");
    if (!(x >= -limit && x < limit))
      throw py::value_error(std::string(name) + ": index " + std::string(py::repr(py::float_(x))) + " is too large");
    r.mutable_data()[i] = static_cast<long long>(x);
  }
  return r;
}

template <class E>
E parse_enum(const std::string& value, const char* name, std::initializer_list<std::pair<const char*, E>> options) {
  std::string known;
  for (const auto& [key, e] : options) {
    if (value == key) return e;
    known += (known.empty() ? "" : ", ") + std::string("'") + key + "'";
  }
  throw py::value_error(std::string(name) + ": unknown value '" + value + "' (expected one of " + known + ")");
}

Transform parse_transform(const std::string& s) {
  return parse_enum<Transform>(
      s, "transform",
      {{"rigid", Transform::rigid}, {"similarity", Transform::similarity}, {"affine", Transform::affine}});
}

RotationMethod parse_method(const std::string& s) {
  for (RotationMethod m : all_rotation_methods)
    if (to_string(m) == s) return m;
  std::string known;
  for (RotationMethod m : all_rotation_methods)
    known += (known.empty() ? "'" : ", '") + std::string(to_string(m)) + "'";
  throw py::value_error("method: unknown value '" + s + "' (expected one of " + known + ")");
}

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
             const std::string& arap_acceleration, bool arap_warm_start) {
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
                                                  {"on_the_fly", WeightStorage::on_the_fly}});
    o.backend = parse_enum<Backend>(backend, "backend", {{"simd", Backend::simd}, {"scalar", Backend::scalar}});
    o.precompute_budget_bytes = budget_bytes;
    o.arap_iterations = arap_iterations;
    o.arap_acceleration =
        parse_enum<ArapAcceleration>(arap_acceleration, "arap_acceleration",
                                     {{"none", ArapAcceleration::none}, {"anderson", ArapAcceleration::anderson}});
    o.arap_warm_start = arap_warm_start;
    o.centroids = parse_enum<Centroids>(centroids, "centroids", {{"mls", Centroids::mls}, {"rbf", Centroids::rbf}});
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

  py::array deform(const py::object& points, const py::object& segments, const py::object& out) const {
    return single() ? run<float>(points, segments, out) : run<double>(points, segments, out);
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

  template <class T>
  py::array run(const py::object& points, const py::object& segments, const py::object& out) const {
    const Handles<T> h = moved<T>(points, segments);
    py::array_t<T> result = output<T>(out);
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
      d.deform(h, InterleavedView<T>(target, d.vertex_count(), 3), cancel);
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

/// `self` of a Deformer method, as the Python object: pybind11 hands a method the raw, never-constructed
/// memory of an instance made by `Deformer.__new__` alone, so every method first asks whether __init__
/// constructed the session (session() below). Named as the class in signatures and help().
bool is_deformer(PyObject* o) { return py::isinstance<PyDeformer>(o); }
class DeformerObject : public py::object {
 public:
  PYBIND11_OBJECT_DEFAULT(DeformerObject, py::object, is_deformer)
};

/// Whether pybind11 has constructed the C++ session of this Python object (its own test in the metaclass's
/// "__init__() must be called" check).
bool constructed(const DeformerObject& self) {
  return reinterpret_cast<py::detail::instance*>(self.ptr())->get_value_and_holder().holder_constructed();
}

/// The session of `self`, or TypeError for an instance __init__ never constructed.
PyDeformer& session(const DeformerObject& self) {
  if (!constructed(self))
    throw py::type_error(
        "Deformer: this instance was never initialised (Deformer.__new__ without __init__); "
        "create sessions as mlsdeform.Deformer(vertices, points=..., ...)");
  return self.cast<PyDeformer&>();
}

}  // namespace

// In signatures and help(), `self` is named as the class it must be.
template <>
struct pybind11::detail::handle_type_name<DeformerObject> {
  static constexpr auto name = const_name<PyDeformer>();
};

namespace {

/// A member function of PyDeformer as a binding that checks `self` first (session()).
template <class R, class... A>
auto on_session(R (PyDeformer::*f)(A...) const) {
  return [f](const DeformerObject& self, A... a) -> R { return (session(self).*f)(std::forward<A>(a)...); };
}
template <class R, class... A>
auto on_session(R (PyDeformer::*f)(A...)) {
  return [f](const DeformerObject& self, A... a) -> R { return (session(self).*f)(std::forward<A>(a)...); };
}

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

PYBIND11_MODULE(_mlsdeform, m) {
  m.doc() = "mlsdeform: as-rigid-as-possible MLS deformation and batched rotation fits (C++ core).";
  g_main_thread = py::module_::import("threading").attr("main_thread")().attr("ident").cast<unsigned long>();
  m.attr("__version__") = std::to_string(MLSDEFORM_VERSION_MAJOR) + "." + std::to_string(MLSDEFORM_VERSION_MINOR) +
                          "." + std::to_string(MLSDEFORM_VERSION_PATCH);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const std::invalid_argument& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const std::out_of_range& e) {
      PyErr_SetString(PyExc_IndexError, e.what());
    } catch (const std::logic_error& e) {  // a use error, such as a moved-from session
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  py::class_<PyDeformer> deformer(m, "Deformer",
                                  "A deformation session; see mlsdeform.Deformer in the Python package.");
  deformer
      .def(py::init<const py::object&, const py::object&, const py::object&, const std::string&, double,
                    const std::string&, const std::string&, int, const std::string&, const std::string&, std::size_t,
                    const py::object&, const py::object&, int, const std::string&, const py::object&,
                    const std::string&, bool>(),
           py::arg("vertices"), py::kw_only(), py::arg("points") = py::none(), py::arg("segments") = py::none(),
           py::arg("transform") = "rigid", py::arg("exponent") = 2.0, py::arg("method") = "axis_angle",
           py::arg("segment_weight") = "paper_constant", py::arg("threads") = 0,
           py::arg("weight_storage") = "automatic", py::arg("backend") = "simd",
           py::arg("precompute_budget_bytes") = std::size_t(32) << 20, py::arg("dtype") = py::none(),
           py::arg("faces") = py::none(), py::arg("arap_iterations") = 0, py::arg("centroids") = "mls",
           py::arg("region") = py::none(), py::arg("arap_acceleration") = "none", py::arg("arap_warm_start") = false,
           R"(Deformer(vertices, *, points=None, segments=None, transform="rigid", exponent=2.0,
method="axis_angle", segment_weight="paper_constant", threads=0, weight_storage="automatic",
backend="simd", precompute_budget_bytes=32 MiB, dtype=None, faces=None, arap_iterations=0, centroids="mls",
region=None, arap_acceleration="none", arap_warm_start=False)

A deformation session (paper Sec. 5): precomputes what depends on the rest pose only.
vertices: (n, 3) rest positions; float32 arrays make a float32 session, anything else float64 (or force
with dtype=). points: (k, 3) rest positions of point handles; segments: a pair (A, B) of (s, 3) arrays of
segment end points. transform: "rigid" | "similarity" | "affine"; exponent: u in w = |p - v|^-u (>= 1);
method: "axis_angle" (the paper's) | "horn_quaternion" | "horn_matrix" | "kanatani" | "svd";
segment_weight: "paper_constant" | "exact_integral"; threads: 0 = all cores; weight_storage:
"automatic" | "precomputed" | "on_the_fly"; faces: (m, 3) vertex indices of the mesh's triangles, needed for
arap_iterations > 0: that many surface-ARAP iterations after MLS (each handle's nearest vertex held where MLS
put it); centroids: "mls" (eq. 2) | "rbf" (q* = g(p*), the RBF interpolant of the handles: the paper's
Sec. 7-8); region: None (the whole model) or the indices of the vertices that may move (the others stay
bitwise at rest; their neighbours next to the region are held, so the result stays continuous; not with
arap_iterations); arap_acceleration: "none" | "anderson" (Anderson-accelerated ARAP iterations: a lower
energy in the same count); arap_warm_start: start each frame's ARAP iterations from the last frame's result
(interactive dragging), from MLS after a jump of the handles. Raises ValueError on bad input (the library's message); Ctrl-C stops the set-up
(KeyboardInterrupt).)")
      .def("deform", on_session(&PyDeformer::deform), py::kw_only(), py::arg("points") = py::none(),
           py::arg("segments") = py::none(), py::arg("out") = py::none(),
           R"(deform(*, points=None, segments=None, out=None) -> (n, 3) array

Deformed vertices for the moved handles: points (k, 3), segments (C, D); a kind not given keeps the
session's current targets (set_point_target / set_segment_target; initially the rest handles). out: a
C-contiguous, writeable (n, 3) array of the session's dtype, written in place with no copy and returned;
None allocates a new one. The GIL is released while deforming. On bad input raises ValueError/TypeError and
writes nothing; a deformed position the dtype cannot hold raises ValueError naming the vertex (out has then
been written over; with arap_iterations it is untouched). With arap_iterations > 0, Ctrl-C stops the frame
between iterations: KeyboardInterrupt, out untouched.)")
      .def("set_point_target", on_session(&PyDeformer::set_point_target), py::arg("i"), py::arg("target"),
           "Move point handle i's target (3 numbers) for later deform() calls; IndexError if out of range.")
      .def("set_segment_target", on_session(&PyDeformer::set_segment_target), py::arg("i"), py::arg("a"), py::arg("b"),
           "Move segment handle i's target end points a, b for later deform() calls.")
      .def("transform_handles", on_session(&PyDeformer::transform_handles), py::kw_only(),
           py::arg("points") = py::none(), py::arg("segments") = py::none(), py::arg("rotation") = py::none(),
           py::arg("translation") = py::none(), py::arg("pivot") = py::none(),
           R"(transform_handles(*, points=None, segments=None, rotation=None, translation=None, pivot=None)

Move a group of handles as one rigid body: the targets of the point handles `points` and the segment
handles `segments` (integer indices) become their REST positions under x -> R (x - pivot) + pivot + t.
rotation: a proper 3 x 3 rotation (default the identity), orthonormal to 64 eps of the session's dtype;
translation, pivot: 3 numbers (default zero). Other targets are kept. IndexError for an index out of range,
ValueError for a reflection, a non-orthonormal or non-finite matrix; on error no target changes.)")
      .def_property_readonly("targets", on_session(&PyDeformer::targets),
                             "The current targets: {'points': (k, 3), 'segments': ((s, 3), (s, 3))} (copies).")
      .def_property_readonly("vertex_count", on_session(&PyDeformer::vertex_count), "Number of vertices n.")
      .def_property_readonly("point_count", on_session(&PyDeformer::point_count), "Number of point handles k.")
      .def_property_readonly("segment_count", on_session(&PyDeformer::segment_count), "Number of segment handles s.")
      .def_property_readonly("dtype", on_session(&PyDeformer::dtype), "The session's dtype: float32 or float64.")
      .def_property_readonly("memory_bytes", on_session(&PyDeformer::memory_bytes), "Bytes held by the precomputation.")
      .def_property_readonly("uses_precomputed_weights", on_session(&PyDeformer::uses_precomputed_weights),
                             "Whether the weights are streamed from a table (True) or recomputed per frame.")
      .def("_time_cpp_deform", on_session(&PyDeformer::time_cpp_deform), py::kw_only(), py::arg("points") = py::none(),
           py::arg("segments") = py::none(), py::arg("out") = py::none(), py::arg("reps") = 10,
           "Seconds per frame of reps C++ deform calls (no Python in the loop): for python/bench/overhead.py.");
  {
    // pybind11 ignores a second __init__ on a constructed instance without a word (the call returns None
    // and the session keeps its old model): refuse it instead, and keep the constructor's docstring. The
    // wrapper is not named "__init__": pybind11 would take it for a constructor and skip it the same way.
    const py::object init = deformer.attr("__init__");
    const std::string doc = py::str(init.attr("__doc__"));
    py::options only_doc;
    only_doc.disable_function_signatures();
    deformer.attr("__init__") = py::cpp_function(
        [init](const DeformerObject& self, const py::args& args, const py::kwargs& kwargs) {
          if (constructed(self))
            throw std::runtime_error("Deformer: __init__ called on an initialised session (make a new Deformer)");
          init(self, *args, **kwargs);
        },
        py::name("Deformer"), py::is_method(deformer), py::doc(doc.c_str()));
  }

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
  m.def(
      "active_isa", [] { return std::string(to_string(active_isa())); },
      "The instruction set the kernels use: 'scalar', 'sse4_2', 'avx2' or 'avx512'.");
  m.def(
      "supported_isas",
      [] {
        std::vector<std::string> r;
        for (Isa i : supported_isas()) r.emplace_back(to_string(i));
        return r;
      },
      "The instruction sets this CPU runs, best last.");
  m.def(
      "set_isa",
      [](const std::string& name) {
        for (Isa i : {Isa::scalar, Isa::sse4_2, Isa::avx2, Isa::avx512})
          if (to_string(i) == name) return set_isa(i);
        throw py::value_error("set_isa: unknown instruction set '" + name + "'");
      },
      py::arg("isa"), "Force an instruction set (ValueError if this CPU cannot run it). Not thread-safe.");
}
