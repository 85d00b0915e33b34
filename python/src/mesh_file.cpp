// PyMesh (files.hpp): the files library's mesh read, built from arrays, reported and encoded for Python.
#include "python/src/files.hpp"

#include "python/src/arrays.hpp"

#include "core/files/carry.hpp"
#include "core/files/handles_file.hpp"

#include <pybind11/stl.h>

#include <string>
#include <utility>
#include <vector>

namespace mlsdeform::python {

bool single_precision(const py::object& dtype) {
  const py::dtype dt = py::dtype::from_args(dtype);
  if (dt.equal(py::dtype::of<float>())) return true;
  if (dt.equal(py::dtype::of<double>())) return false;
  throw py::type_error("dtype: expected float32 or float64, got " + std::string(py::str(py::object(dt))));
}

files::NormalsOut parse_normals(const std::string& normals) {
  return parse_enum<files::NormalsOut>(
      normals, "normals", {{"input", files::NormalsOut::input}, {"computed", files::NormalsOut::computed}});
}

std::optional<files::CoordinateType> parse_output_type(const py::object& output_type) {
  if (output_type.is_none()) return std::nullopt;
  return parse_enum<files::CoordinateType>(
      py::str(output_type), "output_type",
      {{"float32", files::CoordinateType::float32}, {"float64", files::CoordinateType::float64}});
}

PyMesh PyMesh::read(const std::string& path, const py::object& dtype, std::size_t max_bytes) {
  const bool single = single_precision(dtype);
  const py::gil_scoped_release release;
  if (single) return PyMesh{files::read_mesh<float>(path, max_bytes), path};
  return PyMesh{files::read_mesh<double>(path, max_bytes), path};
}

namespace {

template <class T>
files::BasicMesh<T> mesh_of(const Array<T>& v, const py::array_t<long long>& counts,
                            const py::array_t<long long>& indices) {
  files::BasicMesh<T> m;
  m.vertices.resize(v.shape(0), 3);
  std::copy(v.data(), v.data() + v.size(), m.vertices.data());
  if (!m.vertices.allFinite()) throw py::value_error("vertices: a coordinate is not finite");
  long long at = 0;
  const long long n = v.shape(0);
  for (py::ssize_t f = 0; f < counts.size(); ++f) {
    const long long c = counts.data()[f];
    if (c < 3) throw py::value_error("faces: face " + std::to_string(f) + " has " + std::to_string(c) + " vertices");
    if (at + c > indices.size()) throw py::value_error("faces: the counts add up to more than the indices");
    for (long long k = at; k < at + c; ++k) {
      const long long i = indices.data()[k];
      if (i < 0 || i >= n)
        throw py::value_error("faces: index " + std::to_string(i) + " is out of range (" + std::to_string(n) +
                              " vertices)");
      m.face_indices.push_back(std::uint32_t(i));
    }
    at += c;
    m.face_start.push_back(std::uint32_t(m.face_indices.size()));
  }
  if (at != indices.size()) throw py::value_error("faces: the counts add up to fewer than the indices");
  return m;
}

}  // namespace

PyMesh PyMesh::from_arrays(const py::object& vertices, const py::object& counts, const py::object& indices) {
  const auto c = integer_indices(counts, "faces.counts", "an integer array");
  const auto i = integer_indices(indices, "faces.indices", "an integer array");
  const bool single = py::isinstance<py::array>(vertices) &&
                      py::reinterpret_borrow<py::array>(vertices).dtype().equal(py::dtype::of<float>());
  if (single) return PyMesh{mesh_of<float>(as_n3<float>(vertices, "vertices"), c, i), ""};
  return PyMesh{mesh_of<double>(as_n3<double>(vertices, "vertices"), c, i), ""};
}

py::tuple PyMesh::attributes(const std::string& out_path, const std::string& normals) const {
  return visit([&](const auto& m) {
    const files::NormalsOut n = parse_normals(normals);
    // As the program decides (job.cpp): the input's normals carried where the output's format is the input's.
    const bool same = !path.empty() && files::format_extension(path) == files::format_extension(out_path);
    const auto fate = n == files::NormalsOut::input && same && m.extras.has_normals() ? files::InputNormals::transformed
                                                                                      : files::InputNormals::kept;
    const files::AttributeReport r = files::attribute_report(m, out_path, n, fate);
    return py::make_tuple(r.kept, r.transformed, r.dropped);
  });
}

py::bytes PyMesh::encode(const std::string& out_path, bool ply_ascii, const std::string& normals,
                         const py::object& output_type) const {
  files::check_output_format(out_path);
  const files::WriteOptions w{true, ply_ascii ? files::PlyEncoding::ascii : files::PlyEncoding::binary,
                              parse_normals(normals), parse_output_type(output_type)};
  std::string bytes;
  visit([&](const auto& m) {
    if (w.normals == files::NormalsOut::computed && m.face_count() == 0)
      throw files::InputError(this->path, "normals='computed' needs a surface, and the mesh has no faces");
    files::check_fits_output(m, w, path, "");
    const py::gil_scoped_release release;
    bytes = files::encode_mesh(m, out_path, w);
  });
  return py::bytes(bytes);
}

namespace {

template <class T>
py::tuple handles_as_arrays(const Handles<T>& h) {
  return py::make_tuple(from_points<T>(h.points),
                        py::make_tuple(from_points<T>(h.segment_a), from_points<T>(h.segment_b)));
}

template <class T, class V>
py::tuple resolved(const files::HandlesFile& file, const Array<V>& v) {
  PointsRowMajor<V> p(v.shape(0), 3);
  std::copy(v.data(), v.data() + v.size(), p.data());
  const files::ResolvedHandles<T> r = files::resolve_handles<T>(file, p);
  py::list frames;
  for (const auto& f : r.frames) {
    const py::tuple t = handles_as_arrays<T>(f);
    frames.append(py::make_tuple(t[0], t[1]));
  }
  const py::tuple rest = handles_as_arrays<T>(r.rest);
  py::object region = py::none();
  if (!r.region.empty()) region = py::array(py::cast(std::vector<long long>(r.region.begin(), r.region.end())));
  return py::make_tuple(rest[0], rest[1], frames, region, file.animated());
}

}  // namespace

py::tuple read_handles_arrays(const std::string& path, const py::object& vertices, const py::object& dtype) {
  const bool single = single_precision(dtype);
  files::HandlesFile file;
  {
    const py::gil_scoped_release release;
    file = files::read_handles(path);
  }
  // The vertices as read (float32 or float64): a handle on a vertex takes its position exactly.
  const bool v_single = py::isinstance<py::array>(vertices) &&
                        py::reinterpret_borrow<py::array>(vertices).dtype().equal(py::dtype::of<float>());
  if (v_single) {
    const Array<float> v = as_n3<float>(vertices, "vertices");
    return single ? resolved<float>(file, v) : resolved<double>(file, v);
  }
  const Array<double> v = as_n3<double>(vertices, "vertices");
  return single ? resolved<float>(file, v) : resolved<double>(file, v);
}

}  // namespace mlsdeform::python
