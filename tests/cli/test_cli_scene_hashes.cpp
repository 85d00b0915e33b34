// Bitwise regression guard for restructuring (moving stages between files, sharing helpers, splitting the
// deformer): the demo scenes of `mlsdeform demo` are deformed by both backends in float and double, and a hash
// of every output bit must stay what it was when this test was written. The SIMD kernels compute the same
// operations in every lane on every instruction set, fusing a multiply and an add only where they say so
// (xsimd::fma; the compiler may not fuse: -ffp-contract=off), so one hash would hold for the ISAs with FMA and
// another for SSE4.2, where xsimd::fma rounds twice (key "simd_nofma"); the scalar backend has its own. AVX-512
// has its own key ("simd_avx512", AVX2's "simd"): there WeightStorage::automatic takes the precomputed weights
// where AVX2 takes the table (core/src/deformer/precompute.cpp), and the two paths round differently.
//
// A change that is meant to alter results (a new algorithm, a different rounding) updates the table below, and
// its commit says why; the failure message prints the new hashes. A change meant to keep behaviour must not.
#include "tests/support/isa_guard.hpp"
#include "tools/cli/scenes.hpp"

#include <mlsdeform/dispatch.hpp>

#include "tests/support/catch.hpp"

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <string>

using namespace mlsdeform;
using namespace mlsdeform::files;
using namespace mlsdeform::cli;

namespace {

/// FNV-1a over the bytes of the result (the doubles that run_scene gives back: exact copies of T's values).
std::uint64_t hash_points(const Points<double>& p) {
  std::uint64_t h = 1469598103934665603ull;
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (Eigen::Index j = 0; j < 3; ++j) {
      unsigned char b[sizeof(double)];
      const double v = p(i, j);
      std::memcpy(b, &v, sizeof v);
      for (unsigned char c : b) h = (h ^ c) * 1099511628211ull;
    }
  return h;
}

std::vector<Scene> scenes() {
  std::vector<Scene> s;
  const Mesh human = read_mesh(MLSDEFORM_SOURCE_DIR "/data/human_man.obj");
  for (Transform t : {Transform::rigid, Transform::similarity, Transform::affine})
    s.push_back(human_bend_scene(human, 3, 60, t));
  s.push_back(bar_twist_scene(3, 180));
  s.push_back(cylinder_scene(3.0, 2, 120));
  s.push_back(bar_bend_scene(2, 2));
  return s;
}

struct Expected {
  const char* key;
  std::uint64_t hash;
};

// Written by this test's failure message at commit time (g++ 12, Debian 12), one table per architecture. The
// x86-64 and aarch64 results differ in their last bits even on the scalar backend, every product rounded on both
// (-ffp-contract=off): glibc's libm is not the same code on both, and some of its functions round differently
// (on 200,000 arguments, Debian 12's glibc 2.36: hypot, which the segment weights call, acosf and atan2f differ;
// pow, exp, log, sin, cos, expm1, log1p and their float forms agree), and long double is x87's 80 bits on one
// and IEEE binary128 on the other (the segment rule's Gauss-Legendre nodes, core/src/deformer/weights.hpp), and
// Eigen's vectorised expressions fuse on aarch64 (its NEON pmadd is vfmaq wherever __ARM_FEATURE_FMA is defined,
// as on every aarch64 target; -ffp-contract=off does not reach intrinsics) where x86-64's SSE2 has no FMA: without
// it (-U__ARM_FEATURE_FMA) the scalar double results are x86-64's. NEON's are AVX2's except in two double scenes. The
// aarch64 hashes were written under qemu 10's user-mode emulation, whose arithmetic is IEEE's, bit for bit, fused
// multiply-add and the estimate instructions included (ARM defines those bit for bit), with Debian 12's arm64 glibc,
// whose libm picks no variant by CPU.
const Expected kExpected[] = {
#if defined(__aarch64__)
#include "tests/cli/scene_hashes_aarch64.inc"
#else
#include "tests/cli/scene_hashes.inc"
#endif
};

}  // namespace

TEST_CASE("the demo scenes' results are bitwise what they were", "[cli][regression]") {
  testing::IsaGuard guard;
  std::string actual;
  int mismatches = 0, checked = 0;
  auto check = [&](const std::string& key, std::uint64_t h) {
    char line[160];
    std::snprintf(line, sizeof line, "    {\"%s\", 0x%016" PRIx64 "ull},\n", key.c_str(), h);
    if (actual.find(key + "\"") == std::string::npos) actual += line;
    for (const Expected& e : kExpected)
      if (key == e.key) {
        ++checked;
        if (e.hash != h) {
          ++mismatches;
          UNSCOPED_INFO(key << ": 0x" << std::hex << h << ", expected 0x" << e.hash);
        }
        return;
      }
    ++mismatches;
    UNSCOPED_INFO(key << ": no expected hash");
  };
  for (const Scene& s : scenes()) {
    const std::string stem = s.name + "/" +
                             std::string(s.options.transform == Transform::rigid        ? "rigid"
                                         : s.options.transform == Transform::similarity ? "similarity"
                                                                                        : "affine");
    check(stem + "/float/scalar", hash_points(run_scene<float>(s, Isa::scalar, 1).result));
    check(stem + "/double/scalar", hash_points(run_scene<double>(s, Isa::scalar, 1).result));
    for (Isa isa : supported_isas()) {
      if (isa == Isa::scalar) continue;
      set_isa(isa);
      // NEON fuses as AVX2 does: "simd" in aarch64's table.
      const std::string simd = isa == Isa::sse4_2 ? "/simd_nofma" : isa == Isa::avx512 ? "/simd_avx512" : "/simd";
      check(stem + "/float" + simd, hash_points(run_scene<float>(s, std::nullopt, 0).result));
      check(stem + "/double" + simd, hash_points(run_scene<double>(s, std::nullopt, 0).result));
    }
  }
  INFO("the hashes of this build (tests/cli/scene_hashes.inc):\n" << actual);
  CHECK(mismatches == 0);
  CHECK(checked > 0);
}
