// The splat scenes of the C API (api.hpp): a Gaussian splat file (3DGS PLY, compressed PLY, SPZ without its gzip
// layer, .splat) read by the files library's readers, deformed as `mlsdeform deform` deforms it (the deformer's
// frames, then carry_frame: each splat turned, its SH bands rotated, its scales grown or its covariance mapped),
// packed for the page's renderer (spark_pack.hpp) and written back as 3DGS PLY or SPZ's payload by the library's
// writers. The targets, the frames, the deformed splats and the packed arrays are the scene's buffers, which
// JavaScript views; a pose allocates only carry_frame's scratch (a chunk of splats in double), so the views
// stay valid.
#include "web/src/api.hpp"
#include "web/src/spark_pack.hpp"

#include "core/files/carry.hpp"
#include "core/files/file_io.hpp"
#include "core/files/formats/writer.hpp"
#include "core/files/splat_io.hpp"

#include <mlsdeform/deformer.hpp>
#include <mlsdeform/files_error.hpp>

#include <emscripten/emscripten.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

namespace mlsdeform::web {

struct SplatScene {
  std::string path;
  files::BasicMesh<float> rest, result;
  /// What a pose carries (the splats) and what an export carries as the program does (the splats, and a 3DGS
  /// file's nx ny nz into a PLY of the same format: DeformJob), which needs each vertex's linear part too.
  files::CarryPlan plan, export_plan;
  files::SplatLayout layout;
  int opacity = -1, f_dc[3] = {-1, -1, -1};  ///< vertex properties
  /// Where pack() reads each property in a vertex's record: rot_0..3, scale_0..2, f_dc_0..2, opacity, f_rest_*.
  std::size_t stride = 0, rot_at[4] = {}, scale_at[3] = {}, f_dc_at[3] = {}, opacity_at = 0;
  std::vector<std::size_t> f_rest_at;
  std::optional<Deformer<float>> deformer;
  Handles<float> moved;
  std::vector<float> targets;  ///< k points, then s segment starts, then s segment ends, xyz each
  PointsRowMajor<float> out;
  std::vector<float> linear, quaternions, scales;
  SparkEncoding encoding;
  std::vector<std::uint32_t> packed, sh1, sh2, sh3;
  std::string bytes;  ///< the last export
};

namespace {

float at(const unsigned char* row, std::size_t offset) {
  float x;
  std::memcpy(&x, row + offset, 4);
  return x;
}

/// The ranges of the scene's colours and SH bands (a rotation keeps each band's norm per channel, so the
/// norm bounds every coefficient of every pose).
SparkEncoding encoding_of(const SplatScene& s) {
  const auto& v = s.rest.extras.ply->vertices();
  SparkEncoding e;
  const std::size_t n = std::size_t(v.count);
  const int degree = s.layout.sh_degree, k = (degree + 1) * (degree + 1) - 1;
  float lo = 0, hi = 1;
  float band_max[3] = {0, 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* row = v.data.data() + i * s.stride;
    for (int c = 0; c < 3; ++c) {
      const float rgb = float(0.5 + 0.28209479177387814 * double(at(row, s.f_dc_at[c])));
      if (std::isfinite(rgb)) lo = std::min(lo, rgb), hi = std::max(hi, rgb);
      int first = 0;
      for (int l = 1; l <= degree; ++l) {
        double norm = 0;
        for (int j = 0; j < 2 * l + 1; ++j) {
          const double x = at(row, s.f_rest_at[std::size_t(c * k + first + j)]);
          norm += x * x;
        }
        if (std::isfinite(norm)) band_max[l - 1] = std::max(band_max[l - 1], float(std::sqrt(norm)));
        first += 2 * l + 1;
      }
    }
  }
  e.rgb_min = lo, e.rgb_max = hi;
  for (int l = 0; l < 3; ++l) e.sh_max[l] = band_max[l] > 0 ? band_max[l] * 1.0001f : 1;
  return e;
}

/// The result's splats into the renderer's arrays (the properties at the offsets read_scene found); `colour`:
/// their RGBA too, which no pose changes (read_scene packs it once).
void pack(SplatScene& s, bool colour = false) {
  const auto& v = s.result.extras.ply->vertices();
  const std::size_t n = std::size_t(v.count), k = s.f_rest_at.size();
  const int degree = s.layout.sh_degree;
  float f_rest[45];
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* row = v.data.data() + i * s.stride;
    float centre[3], log_scale[3];
    double q[4];
    for (int c = 0; c < 3; ++c) {
      centre[c] = s.result.vertices(Eigen::Index(i), c);
      log_scale[c] = at(row, s.scale_at[c]);
    }
    for (int c = 0; c < 4; ++c) q[c] = at(row, s.rot_at[c]);
    if (colour) {
      const float f_dc[3] = {at(row, s.f_dc_at[0]), at(row, s.f_dc_at[1]), at(row, s.f_dc_at[2])};
      s.packed[4 * i] = pack_colour(at(row, s.opacity_at), f_dc, s.encoding);
    }
    pack_pose(&s.packed[4 * i], centre, log_scale, q, s.encoding);
    if (degree == 0) continue;
    for (std::size_t j = 0; j < k; ++j) f_rest[j] = at(row, s.f_rest_at[j]);
    pack_sh(f_rest, degree, s.encoding, s.sh1.data() + 2 * i, degree >= 2 ? s.sh2.data() + 4 * i : nullptr,
            degree >= 3 ? s.sh3.data() + 4 * i : nullptr);
  }
}

/// The splat file in `bytes` read as the program reads the file `name` (a compressed PLY named plainly .ply is
/// read as what it is), into a scene with its renderer arrays; refused unless it is a splat file of floats.
SplatScene* read_scene(std::string_view data, const std::string& path) {
  using namespace files;
  SplatFormat format = splat_format(path);
  if (format == SplatFormat::none && format_extension(path) == "ply" && looks_like_compressed_ply(data.substr(0, 4096)))
    format = SplatFormat::compressed_ply;
  const std::string kind = format == SplatFormat::none ? mesh_format(path) : "splat";
  auto s = std::make_unique<SplatScene>();
  s->path = path;
  if (data.empty()) throw InputError(path, "empty file");
  s->rest = format == SplatFormat::none ? parse_mesh<float>(*memory_source(data), kind, path)
                                        : decode_splat_file<float>(data, path, format, kDefaultMaxInputBytes);
  const std::optional<SplatLayout> layout = s->rest.extras.ply ? splat_layout(*s->rest.extras.ply, path) : std::nullopt;
  if (!layout) throw InputError(path, "not a Gaussian splat file (no vertex property rot_0: docs/splats.md)");
  s->layout = *layout;
  const auto& v = s->rest.extras.ply->vertices();
  s->opacity = v.find("opacity");
  for (int c = 0; c < 3; ++c) s->f_dc[c] = v.find("f_dc_" + std::to_string(c));
  if (s->opacity < 0 || *std::min_element(s->f_dc, s->f_dc + 3) < 0)
    throw InputError(path, "a splat file needs the properties f_dc_0..2 and opacity (docs/splats.md)");
  for (std::size_t k = 0; k < v.properties.size(); ++k)
    if (v.properties[k].name != "x" && v.properties[k].name != "y" && v.properties[k].name != "z" &&
        v.properties[k].type != PlyScalar::f32 &&
        (v.properties[k].name.rfind("f_", 0) == 0 || v.properties[k].name.rfind("scale_", 0) == 0 ||
         v.properties[k].name.rfind("rot_", 0) == 0 || v.properties[k].name == "opacity"))
      throw InputError(path, "the page shows splats of float properties; " + v.properties[k].name + " is " +
                                 std::string(type_name(v.properties[k].type)));
  if (s->rest.face_count() > 0) throw InputError(path, "a splat file with faces is not shown by the page");
  s->stride = v.stride();
  for (int c = 0; c < 4; ++c) s->rot_at[c] = v.offset(s->layout.rot[std::size_t(c)]);
  for (int c = 0; c < 3; ++c) {
    s->scale_at[c] = v.offset(s->layout.scale[std::size_t(c)]);
    s->f_dc_at[c] = v.offset(std::size_t(s->f_dc[c]));
  }
  s->opacity_at = v.offset(std::size_t(s->opacity));
  for (const std::size_t k : s->layout.f_rest) s->f_rest_at.push_back(v.offset(k));
  s->result = s->rest;
  s->out = s->rest.vertices;
  const std::size_t n = std::size_t(s->rest.vertex_count()), cap = spark_capacity(n);
  s->encoding = encoding_of(*s);
  s->packed.assign(4 * cap, 0);
  if (s->layout.sh_degree >= 1) s->sh1.assign(2 * cap, 0);
  if (s->layout.sh_degree >= 2) s->sh2.assign(4 * cap, 0);
  if (s->layout.sh_degree >= 3) s->sh3.assign(4 * cap, 0);
  pack(*s, true);
  return s.release();
}

Points<float> rows(const float* xyz, int n) {
  if (n < 0) throw std::invalid_argument("negative count");
  if (n > 0 && !xyz) throw std::invalid_argument("null coordinates");
  return n == 0 ? Points<float>(0, 3) : Points<float>(ConstInterleavedView<float>(xyz, n, 3));
}

/// Deforms with the targets: the centres by the deformer, each splat by its centre's frame (carry_frame, as
/// DeformJob: `plan`), then packed for the renderer.
void pose(SplatScene& s, const files::CarryPlan& plan) {
  if (!s.deformer) throw std::logic_error("mls_splats_setup first");
  const Eigen::Index k = s.moved.point_count(), m = s.moved.segment_count();
  const float* t = s.targets.data();
  for (Eigen::Index i = 0; i < k; ++i)
    for (int c = 0; c < 3; ++c) s.moved.points(i, c) = t[3 * i + c];
  for (Eigen::Index i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) {
      s.moved.segment_a(i, c) = t[3 * (k + i) + c];
      s.moved.segment_b(i, c) = t[3 * (k + m + i) + c];
    }
  if (!s.moved.points.allFinite() || !s.moved.segment_a.allFinite() || !s.moved.segment_b.allFinite())
    throw std::invalid_argument("a handle's target is not finite");
  // The positions and the quaternions are bitwise the same whichever frames are asked for (deformer.hpp).
  const bool linear = plan.needs_linear();
  FramesOut<float> frames;
  if (linear) frames.linear = std::span<float>(s.linear);
  frames.quaternions = std::span<float>(s.quaternions);
  frames.scales = std::span<float>(s.scales);
  InterleavedView<float> out(s.out.data(), s.rest.vertex_count(), 3);
  if (frames.any())
    s.deformer->deform(s.moved, out, frames);
  else
    s.deformer->deform(s.moved, out);
  const files::VertexFrames<float> vf{linear ? s.linear.data() : nullptr,
                                      s.quaternions.empty() ? nullptr : s.quaternions.data(),
                                      s.scales.empty() ? nullptr : s.scales.data()};
  files::carry_frame(s.rest, s.result, s.out, plan, vf, 1, s.path);
  pack(s);
}

}  // namespace
}  // namespace mlsdeform::web

using mlsdeform::web::guarded;
using mlsdeform::web::SplatScene;

extern "C" {

/// The splat file in `bytes` (size bytes; an SPZ file without its gzip layer), named `name`: null with
/// mls_last_error() set (the program's message) when refused or when it is no splat file.
EMSCRIPTEN_KEEPALIVE SplatScene* mls_splats_read(const char* bytes, int size, const char* name) {
  return guarded<SplatScene*>(nullptr, [&] {
    if (size < 0 || (size > 0 && !bytes)) throw std::invalid_argument("bad bytes");
    return mlsdeform::web::read_scene(std::string_view(bytes ? bytes : "", std::size_t(size)), name ? name : "");
  });
}
EMSCRIPTEN_KEEPALIVE void mls_splats_delete(SplatScene* s) { delete s; }
EMSCRIPTEN_KEEPALIVE int mls_splats_count(SplatScene* s) { return int(s->rest.vertex_count()); }
EMSCRIPTEN_KEEPALIVE int mls_splats_sh_degree(SplatScene* s) { return s->layout.sh_degree; }
EMSCRIPTEN_KEEPALIVE const float* mls_splats_rest(SplatScene* s) { return s->rest.vertices.data(); }
EMSCRIPTEN_KEEPALIVE const float* mls_splats_centres(SplatScene* s) { return s->result.vertices.data(); }
EMSCRIPTEN_KEEPALIVE const std::uint32_t* mls_splats_packed(SplatScene* s) { return s->packed.data(); }
EMSCRIPTEN_KEEPALIVE int mls_splats_capacity(SplatScene* s) { return int(s->packed.size() / 4); }
/// Band 1, 2 or 3's packed array (null where the degree lacks it).
EMSCRIPTEN_KEEPALIVE const std::uint32_t* mls_splats_sh(SplatScene* s, int band) {
  const auto& a = band == 1 ? s->sh1 : band == 2 ? s->sh2 : s->sh3;
  return a.empty() ? nullptr : a.data();
}
/// The renderer's ranges: 0 rgb_min, 1 rgb_max, 2 ln_scale_min, 3 ln_scale_max, 4..6 bands 1..3's max.
EMSCRIPTEN_KEEPALIVE float mls_splats_encoding(SplatScene* s, int i) {
  const auto& e = s->encoding;
  const float v[7] = {e.rgb_min, e.rgb_max, e.ln_scale_min, e.ln_scale_max, e.sh_max[0], e.sh_max[1], e.sh_max[2]};
  return i >= 0 && i < 7 ? v[i] : 0;
}

/// Builds the deformer over the splat centres with k point and s segment handles (transform: 0 rigid, 1
/// similarity, 2 affine; centroids: 0 MLS, 1 RBF), as the program builds it for the scene's file. 0, or 1 with
/// mls_last_error() set (the scene keeps the deformer it had).
EMSCRIPTEN_KEEPALIVE int mls_splats_setup(SplatScene* s, const float* points, int k, const float* seg_a,
                                          const float* seg_b, int m, int transform, double weight_exponent,
                                          int centroids) {
  using namespace mlsdeform;
  return guarded(1, [&] {
    if (transform < 0 || transform > 2) throw std::invalid_argument("transform must be 0, 1 or 2");
    Options o;
    o.transform = static_cast<Transform>(transform);
    o.weight_exponent = weight_exponent;
    o.centroids = centroids == 1 ? Centroids::rbf : Centroids::mls;
    o.threads = 1;
    // As DeformJob: the input's normals are carried into a PLY of the same format (a 3DGS file's nx ny nz), on
    // export (the renderer has no use for them: a pose leaves them as read).
    const bool normals = files::format_extension(s->path) == "ply" && s->rest.extras.has_normals();
    files::CarryPlan plan = files::carry_plan(s->rest, o.transform, false, s->path);
    files::CarryPlan export_plan = files::carry_plan(s->rest, o.transform, normals, s->path);
    o.affine_frames = o.transform == Transform::affine && export_plan.needs_linear();
    Handles<float> h;
    h.points = web::rows(points, k);
    h.segment_a = web::rows(seg_a, m);
    h.segment_b = web::rows(seg_b, m);
    Deformer<float> d(s->rest.vertices, h, o);
    const std::size_t n = std::size_t(s->rest.vertex_count());
    s->deformer.emplace(std::move(d));
    s->plan = std::move(plan);
    s->export_plan = std::move(export_plan);
    s->moved = h;
    s->targets.assign(std::size_t(k + 2 * m) * 3, 0);
    if (k > 0) std::copy_n(points, 3 * k, s->targets.begin());
    if (m > 0) {
      std::copy_n(seg_a, 3 * m, s->targets.begin() + 3 * k);
      std::copy_n(seg_b, 3 * m, s->targets.begin() + 3 * (k + m));
    }
    s->linear.assign(s->export_plan.needs_linear() ? 9 * n : 0, 0);
    s->quaternions.assign(s->plan.needs_quaternions() ? 4 * n : 0, 0);
    s->scales.assign(s->plan.needs_quaternions() && s->plan.scales ? n : 0, 0);
    return 0;
  });
}
EMSCRIPTEN_KEEPALIVE float* mls_splats_targets(SplatScene* s) { return s->targets.data(); }

/// Deforms with the targets: the centres by the deformer, each splat by its centre's frame (carry_frame, as
/// DeformJob), then packed for the renderer. 0, or 1 with mls_last_error() set (the scene then shows the last
/// pose that deformed).
EMSCRIPTEN_KEEPALIVE int mls_splats_deform(SplatScene* s) {
  return guarded(1, [&] {
    mlsdeform::web::pose(*s, s->plan);
    return 0;
  });
}

/// The deformed scene as the program writes `name`: format 0 a 3DGS PLY (binary, float: encode_ply, byte for
/// byte the program's), 1 SPZ version 3 before its gzip layer (encode_spz_payload; the page gzips it). The
/// bytes are mls_splats_bytes() (mls_splats_bytes_size() of them) until the next export. 0, or 1 with
/// mls_last_error() set (a value the format cannot hold, named).
EMSCRIPTEN_KEEPALIVE int mls_splats_export(SplatScene* s, int format, const char* name) {
  using namespace mlsdeform;
  return guarded(1, [&] {
    const std::string path = name ? name : "";
    s->bytes.clear();
    if (s->export_plan.normals) web::pose(*s, s->export_plan);  // the same pose, the normals carried too
    if (format == 0)
      s->bytes = files::formats::encode_ply<float, float>(s->result, nullptr, files::PlyEncoding::binary);
    else if (format == 1)
      s->bytes = files::encode_spz_payload(files::splat_cloud(s->result, path), path);
    else
      throw std::invalid_argument("format must be 0 (PLY) or 1 (SPZ)");
    return 0;
  });
}
EMSCRIPTEN_KEEPALIVE const char* mls_splats_bytes(SplatScene* s) { return s->bytes.data(); }
EMSCRIPTEN_KEEPALIVE int mls_splats_bytes_size(SplatScene* s) { return int(s->bytes.size()); }

}  // extern "C"
