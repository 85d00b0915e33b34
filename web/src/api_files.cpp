// The files of the C API (api.hpp): meshes and handles files read by the program's own strict readers
// (core/files/formats/, core/files/handles/), so that the page refuses what `mlsdeform deform` refuses, with the
// same message. The page hands over the bytes (a .gz already decompressed by the browser) and the file's
// name, which picks the format as the program's extension does and names the file in messages.
#include "web/src/api.hpp"

#include "core/files/file_io.hpp"
#include "core/files/handles_file.hpp"
#include "core/files/mesh.hpp"

#include <nlohmann/json.hpp>

#include <emscripten/emscripten.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace mlsdeform::web {

/// A mesh as read: its vertices (float, xyz), its polygons (face_start, face_indices as the reader gives
/// them) and their fan triangles (for rendering and ARAP).
struct MeshFile {
  files::BasicMesh<float> mesh;
  std::vector<std::uint32_t> triangles;
};

namespace {

std::string& handles_json() {
  static std::string text;
  return text;
}

std::string text_of(const char* bytes, int size) {
  if (size < 0) throw std::invalid_argument("negative size");
  if (size > 0 && !bytes) throw std::invalid_argument("null bytes");
  return size == 0 ? std::string() : std::string(bytes, std::size_t(size));
}

nlohmann::json xyz(const Eigen::Ref<const Eigen::RowVector3f>& p) { return {p(0), p(1), p(2)}; }

}  // namespace
}  // namespace mlsdeform::web

using mlsdeform::web::guarded;
using mlsdeform::web::MeshFile;

extern "C" {

/// The mesh in `bytes` (size bytes; a .gz's decompressed data) read as the program reads the file `name`:
/// null with mls_last_error() set ("NAME: line N: PROBLEM", the program's message) when it is refused.
EMSCRIPTEN_KEEPALIVE MeshFile* mls_mesh_read(const char* bytes, int size, const char* name) {
  using namespace mlsdeform;
  return guarded<MeshFile*>(nullptr, [&] {
    const std::string path = name ? name : "";
    const std::string format = files::mesh_format(path);
    const std::string data = web::text_of(bytes, size);
    const auto source = files::memory_source(data);
    auto* m = new MeshFile{files::parse_mesh<float>(*source, format, path), {}};
    const auto& start = m->mesh.face_start;
    const auto& index = m->mesh.face_indices;
    for (std::size_t f = 0; f + 1 < start.size(); ++f)
      for (std::uint32_t k = start[f] + 1; k + 1 < start[f + 1]; ++k)
        m->triangles.insert(m->triangles.end(), {index[start[f]], index[k], index[k + 1]});
    return m;
  });
}
EMSCRIPTEN_KEEPALIVE void mls_mesh_delete(MeshFile* m) { delete m; }
EMSCRIPTEN_KEEPALIVE int mls_mesh_vertex_count(MeshFile* m) { return int(m->mesh.vertex_count()); }
EMSCRIPTEN_KEEPALIVE const float* mls_mesh_vertices(MeshFile* m) { return m->mesh.vertices.data(); }
EMSCRIPTEN_KEEPALIVE int mls_mesh_face_count(MeshFile* m) { return int(m->mesh.face_count()); }
/// Face f's corners are face_indices[face_start[f] .. face_start[f + 1]).
EMSCRIPTEN_KEEPALIVE const std::uint32_t* mls_mesh_face_start(MeshFile* m) { return m->mesh.face_start.data(); }
EMSCRIPTEN_KEEPALIVE int mls_mesh_face_index_count(MeshFile* m) { return int(m->mesh.face_indices.size()); }
EMSCRIPTEN_KEEPALIVE const std::uint32_t* mls_mesh_face_indices(MeshFile* m) { return m->mesh.face_indices.data(); }
EMSCRIPTEN_KEEPALIVE int mls_mesh_triangle_count(MeshFile* m) { return int(m->triangles.size() / 3); }
EMSCRIPTEN_KEEPALIVE const std::uint32_t* mls_mesh_triangles(MeshFile* m) { return m->triangles.data(); }

/// The handles file `text` (size bytes, named `name` in messages) parsed and resolved against the n vertices
/// (xyz) as `mlsdeform deform` does, as JSON: {"points": [{"rest", "target", "vertex"}], "segments": [{"restA",
/// "restB", "targetA", "targetB", "vertices"}], "groups": [{"points", "segments"}], "region": [...]}, the
/// targets those of the first frame (groups' motions applied), coordinates the floats the program deforms
/// with. Null with mls_last_error() set when refused. Valid until the next call.
EMSCRIPTEN_KEEPALIVE const char* mls_handles_read(const char* text, int size, const char* name, const float* vertices,
                                                  int n) {
  using namespace mlsdeform;
  return guarded<const char*>(nullptr, [&] {
    if (n < 0 || (n > 0 && !vertices)) throw std::invalid_argument("bad vertices");
    const std::string data = web::text_of(text, size);
    const files::HandlesFile file = files::parse_handles(data, name ? name : "");
    PointsRowMajor<float> v(n, 3);
    if (n > 0) v = Eigen::Map<const PointsRowMajor<float>>(vertices, n, 3);
    const auto resolved = files::resolve_handles<float>(file, v);
    const Handles<float>& rest = resolved.rest;
    const Handles<float>& first = resolved.frames.front();
    nlohmann::json out = {{"points", nlohmann::json::array()},
                          {"segments", nlohmann::json::array()},
                          {"groups", nlohmann::json::array()},
                          {"region", resolved.region}};
    for (Eigen::Index i = 0; i < rest.point_count(); ++i) {
      const auto& spec = file.points[std::size_t(i)];
      out["points"].push_back({{"rest", web::xyz(rest.points.row(i))},
                               {"target", web::xyz(first.points.row(i))},
                               {"vertex", spec.vertex ? std::int64_t(*spec.vertex) : std::int64_t(-1)}});
    }
    for (Eigen::Index i = 0; i < rest.segment_count(); ++i) {
      const auto& spec = file.segments[std::size_t(i)];
      nlohmann::json ends = nullptr;
      if (spec.vertices) ends = {(*spec.vertices)[0], (*spec.vertices)[1]};
      out["segments"].push_back({{"restA", web::xyz(rest.segment_a.row(i))},
                                 {"restB", web::xyz(rest.segment_b.row(i))},
                                 {"targetA", web::xyz(first.segment_a.row(i))},
                                 {"targetB", web::xyz(first.segment_b.row(i))},
                                 {"vertices", ends}});
    }
    for (const auto& g : file.groups) out["groups"].push_back({{"points", g.points}, {"segments", g.segments}});
    web::handles_json() = out.dump();
    return web::handles_json().c_str();
  });
}

}  // extern "C"
