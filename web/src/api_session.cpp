// The deformation session of the C API (api.hpp): a Deformer<float> with buffers in the module's memory that
// JavaScript views as Float32Arrays: the handles' targets (written by the page) and the deformed vertices (read
// by it). deform() copies the targets into the session's Handles, whose sizes never change, and writes the
// output buffer in place: a frame allocates nothing.
#include "web/src/api.hpp"

#include <mlsdeform/deformer.hpp>

#include <emscripten/emscripten.h>

#include <malloc.h>

#include <optional>
#include <vector>

namespace mlsdeform::web {

std::string& last_error() {
  static std::string message;
  return message;
}

namespace {

/// Rows of an interleaved xyz buffer as an n x 3 matrix.
Points<float> rows(const float* xyz, int n) {
  if (n < 0) throw std::invalid_argument("negative count");
  if (n > 0 && !xyz) throw std::invalid_argument("null coordinates");
  return n == 0 ? Points<float>(0, 3) : Points<float>(ConstInterleavedView<float>(xyz, n, 3));
}

}  // namespace

struct Session {
  Deformer<float> deformer;
  Handles<float> moved;
  std::vector<float> targets;  ///< k points, then s segment starts, then s segment ends, xyz each
  std::vector<float> out;      ///< n vertices, xyz

  Session(Deformer<float> d, const Handles<float>& rest)
      : deformer(std::move(d)), moved(rest), out(std::size_t(deformer.vertex_count()) * 3) {
    const Eigen::Index k = rest.point_count(), s = rest.segment_count();
    targets.resize(std::size_t(k + 2 * s) * 3);
    for (Eigen::Index i = 0; i < k; ++i)
      for (int c = 0; c < 3; ++c) targets[std::size_t(3 * i + c)] = rest.points(i, c);
    for (Eigen::Index i = 0; i < s; ++i)
      for (int c = 0; c < 3; ++c) {
        targets[std::size_t(3 * (k + i) + c)] = rest.segment_a(i, c);
        targets[std::size_t(3 * (k + s + i) + c)] = rest.segment_b(i, c);
      }
  }

  void deform() {
    const Eigen::Index k = moved.point_count(), s = moved.segment_count();
    for (Eigen::Index i = 0; i < k; ++i)
      for (int c = 0; c < 3; ++c) moved.points(i, c) = targets[std::size_t(3 * i + c)];
    for (Eigen::Index i = 0; i < s; ++i)
      for (int c = 0; c < 3; ++c) {
        moved.segment_a(i, c) = targets[std::size_t(3 * (k + i) + c)];
        moved.segment_b(i, c) = targets[std::size_t(3 * (k + s + i) + c)];
      }
    deformer.deform(moved, InterleavedView<float>(out.data(), deformer.vertex_count(), 3));
  }
};

}  // namespace mlsdeform::web

using mlsdeform::web::guarded;
using mlsdeform::web::Session;

extern "C" {

EMSCRIPTEN_KEEPALIVE const char* mls_last_error() { return mlsdeform::web::last_error().c_str(); }

/// A session over n vertices (xyz interleaved), m triangles (null and 0 without: no ARAP), k point handles and
/// s segment handles (ends a and b). transform: 0 rigid, 1 similarity, 2 affine; centroids: 0 MLS, 1 RBF;
/// isa: -1 the active one (WebAssembly SIMD), 0 the scalar reference. region: the region_count vertices that
/// may move (Options::region; none: all).
EMSCRIPTEN_KEEPALIVE Session* mls_session_create(const float* vertices, int n, const int* triangles, int m,
                                                 const float* points, int k, const float* seg_a, const float* seg_b,
                                                 int s, int transform, double weight_exponent, int centroids,
                                                 int arap_iterations, int isa, const int* region, int region_count) {
  using namespace mlsdeform;
  return guarded<Session*>(nullptr, [&] {
    if (transform < 0 || transform > 2) throw std::invalid_argument("transform must be 0, 1 or 2");
    if (centroids < 0 || centroids > 1) throw std::invalid_argument("centroids must be 0 (mls) or 1 (rbf)");
    if (isa < -1 || isa > 0) throw std::invalid_argument("isa must be -1 (active) or 0 (scalar)");
    Options o;
    o.transform = static_cast<Transform>(transform);
    o.weight_exponent = weight_exponent;
    o.centroids = centroids == 1 ? Centroids::rbf : Centroids::mls;
    o.arap_iterations = arap_iterations;
    if (isa == 0) o.isa = Isa::scalar;
    o.threads = 1;
    if (region_count < 0 || (region_count > 0 && !region)) throw std::invalid_argument("bad region");
    o.region.assign(region, region + region_count);
    Handles<float> h;
    h.points = web::rows(points, k);
    h.segment_a = web::rows(seg_a, s);
    h.segment_b = web::rows(seg_b, s);
    const Points<float> rest = web::rows(vertices, n);
    if (m < 0) throw std::invalid_argument("negative triangle count");
    if (m > 0) {
      if (!triangles) throw std::invalid_argument("null triangles");
      const Triangles t = Eigen::Map<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(triangles, m, 3);
      return new Session(Deformer<float>(rest, t, h, o), h);
    }
    return new Session(Deformer<float>(rest, h, o), h);
  });
}

EMSCRIPTEN_KEEPALIVE void mls_session_delete(Session* s) { delete s; }
/// Bytes of the module's heap in use (malloc's count), for the tests of web/tests/api.mjs.
EMSCRIPTEN_KEEPALIVE int mls_heap_in_use() { return int(mallinfo().uordblks); }
EMSCRIPTEN_KEEPALIVE float* mls_session_targets(Session* s) { return s->targets.data(); }
EMSCRIPTEN_KEEPALIVE float* mls_session_output(Session* s) { return s->out.data(); }
EMSCRIPTEN_KEEPALIVE int mls_session_vertex_count(Session* s) { return int(s->deformer.vertex_count()); }
EMSCRIPTEN_KEEPALIVE int mls_session_point_count(Session* s) { return int(s->moved.point_count()); }
EMSCRIPTEN_KEEPALIVE int mls_session_segment_count(Session* s) { return int(s->moved.segment_count()); }

/// Deforms with the targets buffer into the output buffer: 0, or 1 with mls_last_error() set (the output is
/// then unspecified).
EMSCRIPTEN_KEEPALIVE int mls_session_deform(Session* s) {
  return guarded(1, [&] {
    s->deform();
    return 0;
  });
}

}  // extern "C"
