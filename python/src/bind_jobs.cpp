// _mlsdeform._DeformJob: files::DeformJob (mlsdeform/files.hpp), the program's `deform` for Python and
// mlsdeform.dask: a mesh file, a handles file and an output name in, each frame's output bytes out (written by
// the caller, all or nothing). The same input, handles file and options give the program's bytes. The GIL is
// released while it reads, builds and encodes; Ctrl-C stops a long frame (SignalWatch).
#include "python/src/bindings.hpp"
#include "python/src/deformer.hpp"
#include "python/src/files.hpp"

#include <mlsdeform/files.hpp>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <variant>

namespace mlsdeform::python {
namespace {

class PyJob {
  std::variant<std::unique_ptr<files::DeformJob<float>>, std::unique_ptr<files::DeformJob<double>>> job_;

  template <class F>
  decltype(auto) visit(F&& f) const {
    return std::visit([&](const auto& j) -> decltype(auto) { return f(*j); }, job_);
  }

 public:
  PyJob(const std::string& mesh, const std::string& handles, const std::string& out, const py::object& dtype,
        const std::string& normals, bool ply_ascii, const py::object& output_type, bool strict_attributes,
        bool overwrite, std::size_t max_input_bytes, const std::string& transform, double exponent,
        const std::string& method, const std::string& segment_weight, int threads, const std::string& weight_storage,
        const std::string& backend, std::size_t budget_bytes, int arap_iterations, const std::string& centroids,
        const std::string& arap_acceleration, bool arap_warm_start) {
    files::JobOptions o;
    o.options = parse_options(transform, exponent, method, segment_weight, threads, weight_storage, backend,
                              budget_bytes, arap_iterations, centroids, arap_acceleration, arap_warm_start, false);
    o.normals = parse_normals(normals);
    o.ply = ply_ascii ? files::PlyEncoding::ascii : files::PlyEncoding::binary;
    o.output_type = parse_output_type(output_type);
    o.strict_attributes = strict_attributes;
    o.force = overwrite;
    o.max_input_bytes = max_input_bytes;
    const bool single = single_precision(dtype);
    const py::gil_scoped_release release;
    if (single)
      job_ = std::make_unique<files::DeformJob<float>>(mesh, handles, out, o);
    else
      job_ = std::make_unique<files::DeformJob<double>>(mesh, handles, out, o);
  }

  std::vector<std::string> outputs() const {
    return visit([](const auto& j) { return j.outputs(); });
  }

  py::dict summary() const {
    return visit([](const auto& j) {
      const files::JobSummary& s = j.summary();
      py::dict d;
      d["vertices"] = s.vertices;
      d["faces"] = s.faces;
      d["dropped_primitives"] = s.dropped_primitives;
      d["points"] = s.points;
      d["segments"] = s.segments;
      d["frames"] = s.frames;
      d["animated"] = s.animated;
      d["region"] = s.region;
      d["splat_sh_degree"] = s.splat_sh_degree;
      d["kept"] = s.kept;
      d["transformed"] = s.transformed;
      d["dropped"] = s.dropped;
      d["setup_seconds"] = s.setup_ms / 1000;
      d["memory_bytes"] = s.memory_bytes;
      return d;
    });
  }

  /// (bytes, deform seconds, encode seconds) of output f.
  py::tuple encode_frame(std::size_t f) {
    files::FrameBytes fb;
    std::visit(
        [&](auto& j) {
          interruptible(true, [&](const CancelCheck& cancel) {
            fb = j->encode_frame(f, cancel ? std::function<bool()>(cancel) : std::function<bool()>());
          });
        },
        job_);
    return py::make_tuple(py::bytes(fb.bytes), fb.deform_ms / 1000, fb.encode_ms / 1000);
  }
};

}  // namespace

void bind_jobs(py::module_& m) {
  py::class_<PyJob>(m, "_DeformJob", "The program's deform on files (mlsdeform.files.DeformJob wraps it).")
      .def(py::init<const std::string&, const std::string&, const std::string&, const py::object&, const std::string&,
                    bool, const py::object&, bool, bool, std::size_t, const std::string&, double, const std::string&,
                    const std::string&, int, const std::string&, const std::string&, std::size_t, int,
                    const std::string&, const std::string&, bool>(),
           py::arg("mesh"), py::arg("handles"), py::arg("out"), py::kw_only(), py::arg("dtype"),
           py::arg("normals") = "input", py::arg("ply_ascii") = false, py::arg("output_type") = py::none(),
           py::arg("strict_attributes") = false, py::arg("overwrite") = false,
           py::arg("max_input_bytes") = files::kDefaultMaxInputBytes, py::arg("transform") = "rigid",
           py::arg("exponent") = 2.0, py::arg("method") = "axis_angle", py::arg("segment_weight") = "paper_constant",
           py::arg("threads") = 0, py::arg("weight_storage") = "automatic", py::arg("backend") = "simd",
           py::arg("precompute_budget_bytes") = std::size_t(64) << 20, py::arg("arap_iterations") = 0,
           py::arg("centroids") = "mls", py::arg("arap_acceleration") = "none", py::arg("arap_warm_start") = false)
      .def_property_readonly("outputs", &PyJob::outputs)
      .def_property_readonly("summary", &PyJob::summary)
      .def("encode_frame", &PyJob::encode_frame, py::arg("frame"));
}

}  // namespace mlsdeform::python
