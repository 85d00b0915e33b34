// mlsdeform.files' compiled part: the files library (core/files/, the program's readers and writers) bound as
// _mlsdeform._Mesh (a mesh file as read, with every attribute it carries, in float or double), _read_handles and
// _frame_path; mlsdeform/files.py is the Python face of them, bind_jobs.cpp binds DeformJob. Files are read and
// encoded with the GIL released; files::InputError becomes ValueError with the library's message.
#include "python/src/arrays.hpp"
#include "python/src/bindings.hpp"
#include "python/src/files.hpp"

#include "core/files/carry.hpp"
#include "core/files/handles_file.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <utility>
#include <vector>

namespace mlsdeform::python {
namespace {

/// (n, k) array of T from `rows` (n k values), or the given shape.
template <class T>
py::array_t<T> copy_array(const T* data, std::vector<py::ssize_t> shape) {
  py::array_t<T> a(shape);
  std::copy(data, data + a.size(), a.mutable_data());
  return a;
}

/// The per-vertex frames array `name` of `obj` (None: null) in T, of `width` values a vertex: (n, width), or
/// (n, 3, 3) for linear; kept alive in `keep`.
template <class T>
const T* frame_array(const py::object& obj, const char* name, std::size_t n, std::vector<py::ssize_t> shape,
                     std::vector<py::array>& keep) {
  if (obj.is_none()) return nullptr;
  const Array<T> a = try_array<T>(obj);
  if (!a) throw py::type_error(std::string(name) + ": expected an array of real numbers, got " + received(obj));
  std::string want = "(" + std::to_string(n);
  for (auto s : shape) want += ", " + std::to_string(s);
  want += shape.empty() ? ",)" : ")";
  bool ok = a.ndim() == py::ssize_t(shape.size() + 1) && a.shape(0) == py::ssize_t(n);
  for (std::size_t k = 0; ok && k < shape.size(); ++k) ok = a.shape(py::ssize_t(k + 1)) == shape[k];
  if (!ok) throw py::value_error(std::string(name) + ": expected shape " + want + ", got " + shape_of(a));
  keep.push_back(a);
  return a.data();
}

template <class T>
PyMesh deformed(const PyMesh& self, const files::BasicMesh<T>& rest, const py::object& positions,
                const py::object& linear, const py::object& quaternions, const py::object& scales) {
  const auto n = std::size_t(rest.vertex_count());
  const Array<T> x = as_n3<T>(positions, "positions");
  if (std::size_t(x.shape(0)) != n)
    throw py::value_error("positions: expected " + std::to_string(n) + " rows (one per vertex), got " +
                          std::to_string(x.shape(0)));
  std::vector<py::array> keep;
  files::VertexFrames<T> f;
  f.linear = frame_array<T>(linear, "linear", n, {3, 3}, keep);
  f.quaternions = frame_array<T>(quaternions, "quaternions", n, {4}, keep);
  f.scales = frame_array<T>(scales, "scales", n, {}, keep);
  // The plan from what was given: splats mapped by linear when no rotations come (an affine fit), grown when
  // scales come (a similarity fit); normals need linear, and carry_frame says so if it is missing.
  const Transform t = !f.quaternions && f.linear ? Transform::affine
                      : f.scales                 ? Transform::similarity
                                                 : Transform::rigid;
  const files::CarryPlan plan = files::carry_plan(rest, t, true, self.path);
  PointsRowMajor<T> p(Eigen::Index(n), 3);
  std::copy(x.data(), x.data() + 3 * n, p.data());
  files::BasicMesh<T> out;
  {
    const py::gil_scoped_release release;
    out = rest;
    files::carry_frame(rest, out, p, plan, f, 0, self.path);
  }
  return PyMesh{std::move(out), self.path};
}

}  // namespace

py::dict PyMesh::frames_needed(const std::string& transform) const {
  return visit([&](const auto& m) {
    const files::CarryPlan plan = files::carry_plan(m, parse_transform(transform), true, path);
    const auto n = py::ssize_t(m.vertex_count());
    py::dict d;
    if (plan.needs_linear()) d["linear"] = py::make_tuple(n, 3, 3);
    if (plan.needs_quaternions()) d["quaternions"] = py::make_tuple(n, 4);
    if (plan.needs_quaternions() && plan.scales) d["scales"] = py::make_tuple(n);
    return d;
  });
}

void bind_files(py::module_& m) {
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const files::InputError& e) {
      // InputError's text is UTF-8 (bytes that are not are escaped as \xNN); decoded leniently all the same, so
      // that no message is ever lost to a decoding error.
      const std::string what = e.what();
      PyObject* text = PyUnicode_DecodeUTF8(what.data(), Py_ssize_t(what.size()), "backslashreplace");
      PyErr_SetObject(PyExc_ValueError, text);
      Py_XDECREF(text);
    }
  });

  py::class_<PyMesh>(m, "_Mesh", "A mesh file as read (mlsdeform.files.Mesh wraps it).")
      .def_static("read", &PyMesh::read, py::arg("path"), py::arg("dtype"), py::arg("max_bytes"))
      .def_static("from_arrays", &PyMesh::from_arrays, py::arg("vertices"), py::arg("counts"), py::arg("indices"))
      .def_property_readonly("dtype", [](const PyMesh& s) { return s.dtype(); })
      .def_property_readonly("path", [](const PyMesh& s) { return s.path; })
      .def_property_readonly("vertices",
                             [](const PyMesh& s) {
                               return s.visit([](const auto& mesh) -> py::array {
                                 using T = typename std::decay_t<decltype(mesh.vertices)>::Scalar;
                                 return copy_array<T>(mesh.vertices.data(), {py::ssize_t(mesh.vertex_count()), 3});
                               });
                             })
      .def_property_readonly(
          "faces",
          [](const PyMesh& s) {
            return s.visit([](const auto& mesh) {
              std::vector<long long> counts(mesh.face_count());
              for (std::size_t f = 0; f < counts.size(); ++f) counts[f] = mesh.face_start[f + 1] - mesh.face_start[f];
              const auto idx = mesh.face_indices;
              return py::make_tuple(
                  py::array(py::cast(counts)),
                  copy_array<std::uint32_t>(idx.data(), {py::ssize_t(idx.size())}).attr("astype")("int64"));
            });
          })
      .def_property_readonly("splat_sh_degree",
                             [](const PyMesh& s) {
                               return s.visit([&](const auto& mesh) {
                                 const auto l =
                                     mesh.extras.ply ? files::splat_layout(*mesh.extras.ply, s.path) : std::nullopt;
                                 return l ? l->sh_degree : -1;
                               });
                             })
      .def("frames_needed", &PyMesh::frames_needed, py::arg("transform"))
      .def(
          "deformed",
          [](const PyMesh& s, const py::object& positions, const py::object& linear, const py::object& quaternions,
             const py::object& scales) {
            return s.visit([&](const auto& mesh) { return deformed(s, mesh, positions, linear, quaternions, scales); });
          },
          py::arg("positions"), py::kw_only(), py::arg("linear") = py::none(), py::arg("quaternions") = py::none(),
          py::arg("scales") = py::none())
      .def("attributes", &PyMesh::attributes, py::arg("out_path"), py::arg("normals"))
      .def("encode", &PyMesh::encode, py::arg("path"), py::arg("ply_ascii"), py::arg("normals"),
           py::arg("output_type"));

  m.def("_read_handles", &read_handles_arrays, py::arg("path"), py::arg("vertices"), py::arg("dtype"));
  m.def(
      "_handles_frames",
      [](const std::string& path) {
        files::HandlesFile f;
        {
          const py::gil_scoped_release release;
          f = files::read_handles(path);  // parsed and checked on its own, not against a mesh
        }
        return py::make_tuple(f.animated() ? f.frames.size() : std::size_t(1), f.animated());
      },
      py::arg("path"));
  m.def("_frame_path", &files::frame_path, py::arg("out"), py::arg("frame"), py::arg("frame_count"));
  m.def("_check_output_format", &files::check_output_format, py::arg("path"));
  m.def("_mesh_format", &files::mesh_format, py::arg("path"));
}

}  // namespace mlsdeform::python
