// The MLS deformer's session: bitwise the same output for any thread count, the stateful API and the
// interleaved output against deform(moved, out), deform as a const call that may run concurrently, the memory
// figures, and no allocation per frame. Exact equality throughout: these change where and how the same
// arithmetic runs, never the arithmetic.
#include "tests/test_deformer_common.hpp"

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <thread>
#include <utility>
#include <vector>

using namespace deformer_test;

TEMPLATE_TEST_CASE("thread-count invariance: bitwise identical output for any thread count", "[deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    const DeformCase<T> sc = random_case<T>(g, 3001, 12, 3);  // 188 blocks, the last one partial
    const Handles<T> moved = transformed(sc.rest, random_rotation(g), random_vector(g));
    Points<T> reference;
    for (int threads : {1, 2, 3, 0, 8}) {
      INFO("threads " << threads);
      Options o;
      o.transform = tr;
      o.threads = threads;
      o.segment_weight = SegmentWeight::exact_integral;
      const Deformer<T> def(sc.vertices, sc.rest, o);
      Points<T> out;
      def.deform(moved, out);
      if (reference.size() == 0)
        reference = out;
      else
        CHECK(out == reference);
    }
  }
}

TEMPLATE_TEST_CASE("the stateful API and the interleaved output agree with deform(moved, out)", "[deformer]", float,
                   double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  INFO("seed " << seed());
  const DeformCase<T> sc = random_case<T>(g, 100, 5, 2);
  Options o;
  o.transform = Transform::similarity;
  Deformer<T> def(sc.vertices, sc.rest, o);
  CHECK(def.vertex_count() == 100);
  CHECK(def.targets().points == sc.rest.points);
  Handles<T> moved = sc.rest;
  moved.points.row(3) += Vector3<T>(T(0.5), T(-0.25), T(1)).transpose();
  moved.segment_a.row(1) += Vector3<T>(T(0.1), T(0.2), T(0.3)).transpose();
  moved.segment_b.row(1) -= Vector3<T>(T(0.3), T(0.1), T(0.2)).transpose();
  def.set_point_target(3, moved.points.row(3).transpose());
  def.set_segment_target(1, moved.segment_a.row(1).transpose(), moved.segment_b.row(1).transpose());
  Points<T> a, b;
  def.deform(a);
  def.deform(moved, b);
  CHECK(a == b);
  // Interleaved (row-major) output: the same values.
  PointsRowMajor<T> buffer(100, 3);
  def.deform(moved, InterleavedView<T>(buffer.data(), 100, 3));
  CHECK(Points<T>(buffer) == b);
  // A new rest pose resets the targets.
  const DeformCase<T> sc2 = random_case<T>(g, 50, 5, 2);
  def.reset_rest_pose(sc2.vertices, sc2.rest);
  CHECK(def.vertex_count() == 50);
  CHECK(def.targets().points == sc2.rest.points);
  Points<T> c;
  def.deform(c);
  const Deformer<T> fresh(sc2.vertices, sc2.rest, o);
  Points<T> d;
  fresh.deform(sc2.rest, d);
  CHECK(c == d);
  // Moves keep the session.
  Deformer<T> moved_def = std::move(def);
  Points<T> e;
  moved_def.deform(e);
  CHECK(e == d);
}

TEMPLATE_TEST_CASE("deform is const and may run concurrently on distinct outputs", "[deformer]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 2000, 10, 2);
  for (int threads : {1, 0}) {
    Options o;
    o.transform = Transform::similarity;
    o.threads = threads;
    const Deformer<T> def(sc.vertices, sc.rest, o);
    const Handles<T> moved = transformed(sc.rest, random_rotation(g), random_vector(g));
    Points<T> expected;
    def.deform(moved, expected);
    Points<T> outs[4];
    std::vector<std::thread> pool;
    for (Points<T>& out : outs) pool.emplace_back([&] { def.deform(moved, out); });
    for (std::thread& th : pool) th.join();
    for (const Points<T>& out : outs) CHECK(out == expected);
  }
}

TEMPLATE_TEST_CASE("memory_bytes reports the table and per-vertex arrays actually held", "[deformer]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const Eigen::Index n = 1000, k = 10, s = 3;  // J = 16 pseudo-handles; 63 blocks of 16 (1008 padded)
  const DeformCase<T> sc = random_case<T>(g, n, k, s);
  const std::size_t np = 1008, J = 16, handles_bytes = 2 * 3 * (k + 2 * s) * sizeof(T);
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    Options o;
    o.transform = tr;
    const Deformer<T> def(sc.vertices, sc.rest, o);
    // deformer/data.hpp: 4 values (omega, A) per vertex and pseudo-handle, or 1 (alpha) for affine; p* and
    // vhat (3 each) per vertex for rigid and similarity, D (1) for similarity; plus the rest and target handles.
    std::size_t values = np * J * (tr == Transform::affine ? 1 : 4);
    if (tr != Transform::affine) values += 6 * np;
    if (tr == Transform::similarity) values += np;
    CHECK(def.memory_bytes() == values * sizeof(T) + handles_bytes);
    CHECK(def.uses_precomputed_weights());
    const std::size_t per_pair = (tr == Transform::affine ? 1 : 4) * sizeof(T);
    const std::size_t per_vertex = (tr == Transform::affine ? 0 : tr == Transform::similarity ? 7 : 6) * sizeof(T);
    std::printf(
        "[memory] %-6s %-10s n = %ld, J = %zu (10 points + 3 segments): memory_bytes() = %zu = %zu B per vertex "
        "and pseudo-handle x %zu x %zu (padded) + %zu B per vertex x %zu + %zu B of handles\n",
        type_name<T>(), name(tr), long(n), J, def.memory_bytes(), per_pair, J, np, per_vertex, np, handles_bytes);
    CHECK(def.memory_bytes() == per_pair * J * np + per_vertex * np + handles_bytes);
  }
}

namespace {
std::atomic<long> g_allocations{0};
std::atomic<bool> g_counting{false};
}  // namespace

// Every non-aligned form of the global operator new/delete, so that each allocation is freed by its own
// family (AddressSanitizer checks alloc-dealloc pairs; the aligned forms stay the runtime's on both sides).
namespace {
void* counted_malloc(std::size_t n) noexcept {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n == 0 ? 1 : n);
}
}  // namespace
void* operator new(std::size_t n) {
  if (void* p = counted_malloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  if (void* p = counted_malloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return counted_malloc(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return counted_malloc(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }

TEMPLATE_TEST_CASE("deform allocates nothing once out has its size (single thread)", "[deformer]", float, double) {
  using T = TestType;
  std::mt19937_64 g(seed());
  const DeformCase<T> sc = random_case<T>(g, 500, 8, 2);
  for (Transform tr : all_transforms) {
    INFO(name(tr));
    Options o;
    o.transform = tr;
    o.threads = 1;  // TBB's own task allocation is outside the library's control
    const Deformer<T> def(sc.vertices, sc.rest, o);
    const Handles<T> moved = transformed(sc.rest, random_rotation(g), random_vector(g));
    Points<T> out(500, 3);
    // (Eigen's dynamic matrices allocate through malloc, which this counter does not see: the library code
    // in deform() uses fixed-size Eigen types only.)
    g_allocations = 0;
    g_counting = true;
    def.deform(moved, out);
    g_counting = false;
    CHECK(g_allocations == 0);
  }
}
