// mlsdeform.Deformer: the session class (deformer.hpp) as Python sees it, its methods checking first that
// __init__ constructed the instance.
#include "python/src/bindings.hpp"
#include "python/src/deformer.hpp"

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>
#include <utility>

namespace mlsdeform::python {
namespace {

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
}  // namespace mlsdeform::python

// In signatures and help(), `self` is named as the class it must be.
template <>
struct pybind11::detail::handle_type_name<mlsdeform::python::DeformerObject> {
  static constexpr auto name = const_name<mlsdeform::python::PyDeformer>();
};

namespace mlsdeform::python {
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

}  // namespace

void bind_deformer(py::module_& m) {
  py::class_<PyDeformer> deformer(m, "Deformer",
                                  "A deformation session; see mlsdeform.Deformer in the Python package.");
  deformer
      .def(py::init<const py::object&, const py::object&, const py::object&, const std::string&, double,
                    const std::string&, const std::string&, int, const std::string&, const std::string&, std::size_t,
                    const py::object&, const py::object&, int, const std::string&, const py::object&,
                    const std::string&, bool, bool>(),
           py::arg("vertices"), py::kw_only(), py::arg("points") = py::none(), py::arg("segments") = py::none(),
           py::arg("transform") = "rigid", py::arg("exponent") = 2.0, py::arg("method") = "axis_angle",
           py::arg("segment_weight") = "paper_constant", py::arg("threads") = 0,
           py::arg("weight_storage") = "automatic", py::arg("backend") = "simd",
           py::arg("precompute_budget_bytes") = std::size_t(64) << 20, py::arg("dtype") = py::none(),
           py::arg("faces") = py::none(), py::arg("arap_iterations") = 0, py::arg("centroids") = "mls",
           py::arg("region") = py::none(), py::arg("arap_acceleration") = "none", py::arg("arap_warm_start") = false,
           py::arg("affine_frames") = false,
           R"(Deformer(vertices, *, points=None, segments=None, transform="rigid", exponent=2.0,
method="axis_angle", segment_weight="paper_constant", threads=0, weight_storage="automatic",
backend="simd", precompute_budget_bytes=64 MiB, dtype=None, faces=None, arap_iterations=0, centroids="mls",
region=None, arap_acceleration="none", arap_warm_start=False, affine_frames=False)

A deformation session (paper Sec. 5): precomputes what depends on the rest pose only.
vertices: (n, 3) rest positions; float32 arrays make a float32 session, anything else float64 (or force
with dtype=). points: (k, 3) rest positions of point handles; segments: a pair (A, B) of (s, 3) arrays of
segment end points. transform: "rigid" | "similarity" | "affine"; exponent: u in w = |p - v|^-u (>= 1);
method: "axis_angle" (the paper's) | "horn_quaternion" | "horn_matrix" | "kanatani" | "svd";
segment_weight: "paper_constant" | "exact_integral"; threads: 0 = all cores; weight_storage:
"automatic" | "precomputed" | "on_the_fly" | "precomputed_weights"; faces: (m, 3) vertex indices of the mesh's triangles, needed for
arap_iterations > 0: that many surface-ARAP iterations after MLS (each handle's nearest vertex held where MLS
put it); centroids: "mls" (eq. 2) | "rbf" (q* = g(p*), the RBF interpolant of the handles: the paper's
Sec. 7-8); region: None (the whole model) or the indices of the vertices that may move (the others stay
bitwise at rest; their neighbours next to the region are held, so the result stays continuous; not with
arap_iterations); arap_acceleration: "none" | "anderson" (Anderson-accelerated ARAP iterations: a lower
energy in the same count); arap_warm_start: start each frame's ARAP iterations from the last frame's result
(interactive dragging), from MLS after a jump of the handles; affine_frames: for transform="affine", also
keep the fit's matrix (a table 3 times the weights', counted in precompute_budget_bytes) so that deform() can
write linear (without it, linear is a ValueError naming the option). Raises ValueError on bad input (the library's message); Ctrl-C stops the set-up
(KeyboardInterrupt).)")
      .def(
          "deform", on_session(&PyDeformer::deform), py::kw_only(), py::arg("points") = py::none(),
          py::arg("segments") = py::none(), py::arg("out") = py::none(), py::arg("quaternions") = py::none(),
          py::arg("rotations") = py::none(), py::arg("scales") = py::none(), py::arg("linear") = py::none(),
          R"(deform(*, points=None, segments=None, out=None, quaternions=None, rotations=None, scales=None, linear=None) -> (n, 3) array

Deformed vertices for the moved handles: points (k, 3), segments (C, D); a kind not given keeps the
session's current targets (set_point_target / set_segment_target; initially the rest handles). out: a
C-contiguous, writeable (n, 3) array of the session's dtype, written in place with no copy and returned;
None allocates a new one. The GIL is released while deforming. On bad input raises ValueError/TypeError and
writes nothing; a deformed position the dtype cannot hold raises ValueError naming the vertex (out has then
been written over; with arap_iterations it is untouched). With arap_iterations > 0, Ctrl-C stops the frame
between iterations: KeyboardInterrupt, out untouched.

Frames: each vertex's transform, written into the caller's preallocated C-contiguous arrays of the session's
dtype (no copy, nothing allocated; None: not wanted): quaternions (n, 4) unit (w, x, y, z) with w >= 0,
rotations (n, 3, 3), scales (n,) (similarity; 1 for rigid), linear (n, 3, 3) the linear part R, s R or the
affine fit's matrix. With arap_iterations the refined local rotations (scales 1); outside a region the identity;
affine sessions give linear only, and only when built with affine_frames=True (otherwise ValueError). A wrong shape is a ValueError, a wrong dtype a TypeError, two outputs (out among them) sharing memory a ValueError naming
them, all before anything is written; the handles may share memory with an output (they are read first).)")
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
}

}  // namespace mlsdeform::python
