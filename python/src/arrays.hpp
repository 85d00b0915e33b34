// Arguments from Python: array-likes converted to the library's types (or a ValueError / TypeError naming
// the argument and what was received), integer indices, thread counts and the option strings.
#pragma once

#include <mlsdeform/mlsdeform.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <utility>

namespace mlsdeform::python {

namespace py = pybind11;

template <class T>
using Array = py::array_t<T, py::array::c_style | py::array::forcecast>;

inline std::string shape_of(const py::array& a) {
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
inline std::string received(const py::handle& obj) {
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
inline std::pair<std::uintptr_t, std::uintptr_t> byte_extent(const py::array& a) {
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
inline bool may_share_memory(const py::array& a, const py::array& b) {
  const auto [a0, a1] = byte_extent(a);
  const auto [b0, b1] = byte_extent(b);
  return a0 < b1 && b0 < a1;
}

/// Refuses two arrays that one call writes and that share memory (views of one buffer: no order of writes
/// gives both their values), with a ValueError naming both; None (an output not wanted) is skipped. Checked
/// after each array's own checks, before anything is written.
inline void check_outputs_apart(std::initializer_list<std::pair<const char*, py::object>> outputs) {
  for (auto i = outputs.begin(); i != outputs.end(); ++i)
    for (auto j = i + 1; j != outputs.end(); ++j)
      if (!i->second.is_none() && !j->second.is_none() &&
          may_share_memory(py::reinterpret_borrow<py::array>(i->second), py::reinterpret_borrow<py::array>(j->second)))
        throw py::value_error(std::string(i->first) + " and " + j->first +
                              " share memory (views of one buffer?): each output needs an array of its own");
}

/// An input of a call that writes `outputs` (arrays; None skipped) while it still reads the input: the input
/// itself, or a copy of it where it shares memory with one of them, so that the call reads the values the
/// caller passed, not ones it has already written over.
template <class T>
Array<T> apart_from(const Array<T>& input, std::initializer_list<py::object> outputs) {
  for (const py::object& o : outputs)
    if (!o.is_none() && may_share_memory(input, py::reinterpret_borrow<py::array>(o)))
      return Array<T>::ensure(input.attr("copy")());
  return input;
}

/// `threads` of every call that takes one, checked in one place so that the session and the batched fit
/// refuse the same values with the same message (1 = the calling thread, 0 = all cores).
inline int checked_threads(int threads) {
  if (threads < 0)
    throw py::value_error("threads: expected 0 (all cores) or a positive number of threads, got " +
                          std::to_string(threads));
  return threads;
}

/// Integer indices (faces, region, handle groups) from any array-like, as a C-contiguous int64 array: integer
/// arrays as they are; float arrays (a mesh read as floats) only where every value is an integer, converted
/// exactly. A fractional, non-finite or too large value is a ValueError naming the argument and the value,
/// never truncated; any other dtype (bool, str, object) is a TypeError. Range checks are the caller's.
inline py::array_t<long long> integer_indices(const py::object& obj, const char* name, const char* expected) {
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

inline Transform parse_transform(const std::string& s) {
  return parse_enum<Transform>(
      s, "transform",
      {{"rigid", Transform::rigid}, {"similarity", Transform::similarity}, {"affine", Transform::affine}});
}

inline RotationMethod parse_method(const std::string& s) {
  for (RotationMethod m : all_rotation_methods)
    if (to_string(m) == s) return m;
  std::string known;
  for (RotationMethod m : all_rotation_methods)
    known += (known.empty() ? "'" : ", '") + std::string(to_string(m)) + "'";
  throw py::value_error("method: unknown value '" + s + "' (expected one of " + known + ")");
}

}  // namespace mlsdeform::python
