// deform(), fit_rotations() and the splat motions allocate nothing once the output has its size. The C
// allocator itself is replaced by a counting one for this test binary (Eigen and std::aligned_alloc call
// malloc directly; operator new ends there too), forwarding to glibc's __libc_* entry points. Not built with
// the sanitizers, which interpose the allocator themselves (tests/CMakeLists.txt skips it when
// MLSDEFORM_SANITIZE is on).
#include <mlsdeform/mlsdeform.hpp>

#include "tests/support/catch.hpp"

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
void __libc_free(void*);
}

namespace {
std::atomic<long> g_allocations{0};
}

extern "C" {
void* malloc(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
void* calloc(std::size_t n, std::size_t m) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(n, m);
}
void* realloc(void* p, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(a, n);
}
void* memalign(std::size_t a, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(a, n);
}
int posix_memalign(void** out, std::size_t a, std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  void* p = __libc_memalign(a, n);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void free(void* p) { __libc_free(p); }
}

using namespace mlsdeform;

namespace {

template <class F>
long allocations_during(F&& f) {
  const long before = g_allocations.load();
  f();
  return g_allocations.load() - before;
}

}  // namespace

TEMPLATE_TEST_CASE("deform and fit_rotations allocate nothing in steady state", "[allocation]", float, double) {
  using T = TestType;
  std::mt19937 rng(5);
  std::uniform_real_distribution<T> u(-1, 1);
  Points<T> v(5000, 3);
  for (Eigen::Index i = 0; i < v.size(); ++i) v.data()[i] = u(rng);
  Handles<T> rest, moved;
  rest.points.resize(7, 3);
  for (Eigen::Index i = 0; i < rest.points.size(); ++i) rest.points.data()[i] = u(rng);
  moved = rest;
  moved.points.col(0).array() += T(0.3);
  for (const std::optional<Isa> isa : {std::optional<Isa>(), std::optional<Isa>(Isa::scalar)})
    for (WeightStorage storage : {WeightStorage::precomputed, WeightStorage::on_the_fly})
      for (Transform tr : {Transform::rigid, Transform::similarity}) {
        INFO("isa " << (isa ? to_string(*isa) : "active") << " storage " << int(storage) << " transform " << int(tr));
        Options o;
        o.isa = isa;
        o.weight_storage = storage;
        o.transform = tr;
        o.threads = 1;  // with more threads TBB's task allocation is its own (scalable allocator, not new)
        Deformer<T> d(v, rest, o);
        Points<T> out;
        // The hook sees allocations at all: the first call sizes `out`.
        CHECK(allocations_during([&] { d.deform(moved, out); }) > 0);
        CHECK(allocations_during([&] { d.deform(moved, out); }) == 0);
        d.set_point_target(2, Vector3<T>(T(0.5), T(0.5), T(0.5)));
        CHECK(allocations_during([&] { d.deform(out); }) == 0);
        // Frames (FramesOut): the caller's arrays, written from the lanes.
        std::vector<T> q(4 * 5000), r(9 * 5000), s(5000), l(9 * 5000);
        CHECK(allocations_during([&] { d.deform(moved, out, FramesOut<T>{q, r, s, l}); }) == 0);
        CHECK(allocations_during([&] { d.deform(out, FramesOut<T>{q, {}, {}, {}}); }) == 0);
      }
  // Affine (precomputed weights only): its frame, the fit's matrix, from the session's second table.
  for (const std::optional<Isa> isa : {std::optional<Isa>(), std::optional<Isa>(Isa::scalar)}) {
    Options o;
    o.isa = isa;
    o.transform = Transform::affine;
    o.affine_frames = true;
    o.threads = 1;
    Deformer<T> d(v, rest, o);
    Points<T> out;
    d.deform(moved, out);
    std::vector<T> l(9 * 5000);
    CHECK(allocations_during([&] { d.deform(moved, out, FramesOut<T>{{}, {}, {}, l}); }) == 0);
  }
  // A region (Options::region): the kernels' output and the targets with the ring's fixed handles are the
  // session's scratch, sized at construction.
  for (const std::optional<Isa> isa : {std::optional<Isa>(), std::optional<Isa>(Isa::scalar)}) {
    Options o;
    o.isa = isa;
    o.threads = 1;
    for (Eigen::Index i = 0; i < v.rows(); i += 3) o.region.push_back(i);
    Deformer<T> d(v, rest, o);
    Points<T> out;
    CHECK(allocations_during([&] { d.deform(moved, out); }) > 0);
    CHECK(allocations_during([&] { d.deform(moved, out); }) == 0);
    PointsRowMajor<T> buffer(v.rows(), 3);
    CHECK(allocations_during([&] { d.deform(moved, InterleavedView<T>(buffer.data(), buffer.rows(), 3)); }) == 0);
    // The region's frames are moved to their rows in place (no scratch).
    std::vector<T> q(4 * 5000), r(9 * 5000), s(5000), l(9 * 5000);
    CHECK(allocations_during([&] { d.deform(moved, out, FramesOut<T>{q, r, s, l}); }) == 0);
  }
  std::vector<T> H(9 * 1000), R(9 * 1000);
  for (T& h : H) h = u(rng);
  for (RotationMethod m : all_rotation_methods) {
    INFO(to_string(m));
    CHECK(allocations_during([&] { fit_rotations(H.data(), R.data(), 1000, m); }) == 0);
    CHECK(allocations_during([&] { fit_rotations_interleaved(H.data(), R.data(), 1000, m); }) == 0);
  }
}

TEMPLATE_TEST_CASE("ARAP refinement allocates nothing in steady state", "[allocation][arap]", float, double) {
  using T = TestType;
  // A strip of 20 x 10 vertices, two triangles per quad; its first and last columns constrained.
  const int nx = 20, ny = 10;
  Points<T> v(nx * ny, 3);
  Triangles f(2 * (nx - 1) * (ny - 1), 3);
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) v.row(i * ny + j) << T(i) / 10, T(j) / 10, T((i * j) % 3) / 50;
  Eigen::Index k = 0;
  for (int i = 0; i + 1 < nx; ++i)
    for (int j = 0; j + 1 < ny; ++j) {
      f.row(k++) << i * ny + j, (i + 1) * ny + j, (i + 1) * ny + j + 1;
      f.row(k++) << i * ny + j, (i + 1) * ny + j + 1, i * ny + j + 1;
    }
  Handles<T> rest;
  rest.points.resize(2 * ny, 3);
  for (int j = 0; j < ny; ++j) rest.points.row(j) = v.row(j), rest.points.row(ny + j) = v.row((nx - 1) * ny + j);
  Handles<T> moved = rest;
  moved.points.col(1).tail(ny).array() += T(0.5);
  // Anderson acceleration's history and its small least-squares solve (on the stack) are the session's too,
  // and so is the warm start's last result (the second and third frames start from it).
  for (ArapAcceleration acceleration : {ArapAcceleration::none, ArapAcceleration::anderson}) {
    INFO("acceleration " << int(acceleration));
    Options o;
    o.arap_warm_start = acceleration == ArapAcceleration::anderson;
    o.threads = 1;  // with more threads TBB's task allocation is its own (scalable allocator, not new)
    o.arap_iterations = 8;
    o.arap_acceleration = acceleration;
    Deformer<T> d(v, f, rest, o);
    Points<T> out;
    CHECK(allocations_during([&] { d.deform(moved, out); }) > 0);
    CHECK(allocations_during([&] { d.deform(moved, out); }) == 0);
    PointsRowMajor<T> buffer(v.rows(), 3);
    CHECK(allocations_during([&] { d.deform(moved, InterleavedView<T>(buffer.data(), buffer.rows(), 3)); }) == 0);
    // The refined rotations as frames: quaternions alone go through the session's scratch, sized once.
    const auto nv = std::size_t(v.rows());
    std::vector<T> q(4 * nv), r(9 * nv), s(nv), l(9 * nv);
    CHECK(allocations_during([&] { d.deform(moved, out, FramesOut<T>{q, {}, {}, {}}); }) == 0);
    CHECK(allocations_during([&] { d.deform(moved, out, FramesOut<T>{q, r, s, l}); }) == 0);
  }
}

TEMPLATE_TEST_CASE("ARAP refinement allocates nothing per iteration with each factorisation", "[allocation][arap]",
                   float, double) {
  using T = TestType;
  // A 30 x 30 grid folded along a diagonal, its first row constrained and its last row moved: large enough
  // for several supernodes, and, with two threads, a cut of the tree into parts and a top.
  const int n = 30;
  Points<T> v(n * n, 3);
  Triangles f(2 * (n - 1) * (n - 1), 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) v.row(i * n + j) << T(i) / 10, T(j) / 10, T(std::abs(i - j)) / 20;
  Eigen::Index k = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      f.row(k++) << i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1;
      f.row(k++) << i * n + j, (i + 1) * n + j + 1, i * n + j + 1;
    }
  std::vector<Eigen::Index> held;
  for (int j = 0; j < n; ++j) held.push_back(j), held.push_back((n - 1) * n + j);
  Points<T> targets(Eigen::Index(held.size()), 3);
  for (std::size_t h = 0; h < held.size(); ++h)
    targets.row(Eigen::Index(h)) =
        v.row(held[h]) + (held[h] >= n ? Points<T>::Constant(1, 3, T(0.3)) : Points<T>::Zero(1, 3));
  std::vector<ArapFactorisation> methods{ArapFactorisation::simplicial, ArapFactorisation::supernodal_mit};
  if (supernodal_factorisation_available()) methods.push_back(ArapFactorisation::supernodal);
  for (const ArapFactorisation m : methods) {
    INFO("factorisation " << int(m));
    // One thread: with more, TBB's task allocation is its own (scalable allocator, not new).
    ArapRefiner<T> r(v, f, held, ArapOptions{1, m});
    Points<T> out;
    CHECK(allocations_during([&] { r.refine(v, targets, 3, out); }) > 0);
    CHECK(allocations_during([&] { r.refine(v, targets, 3, out); }) == 0);
  }
}

TEMPLATE_TEST_CASE("splat motions allocate nothing", "[allocation][splats]", float, double) {
  using T = TestType;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  const std::size_t n = 1000;
  std::vector<T> rot(4 * n), log_scales(3 * n), sh(45 * n), q(4 * n), s(n, T(1.5)), linear(9 * n);
  for (T& x : rot) x = T(g(rng));
  for (T& x : log_scales) x = T(g(rng));
  for (T& x : sh) x = T(g(rng));
  for (std::size_t i = 0; i < n; ++i) {
    double a[4], length = 0;
    for (double& x : a) {
      x = g(rng);
      length += x * x;
    }
    for (std::size_t j = 0; j < 4; ++j) q[4 * i + j] = T(a[j] / std::sqrt(length));
    for (std::size_t j = 0; j < 9; ++j) linear[9 * i + j] = T((j % 4 == 0 ? 1 : 0) + 0.1 * g(rng));
  }
  const SplatArrays<T> a{rot.data(), log_scales.data(), sh.data(), 3};
  rotate_splats<T>(a, n, q.data(), s.data());  // the steady state: TBB's first query of the cores allocates
  CHECK(allocations_during([&] { rotate_splats<T>(a, n, q.data(), s.data()); }) == 0);
  CHECK(allocations_during([&] { transform_splats_affine<T>(a, n, linear.data()); }) == 0);
}
