// fit_count: a fixed workload of batched rotation fits, for counting instructions per fit where the kernels'
// speed cannot be timed (an ISA run under an emulator: tools/insn_per_fit.sh, docs/performance.md). Fits n
// matrices `repeats` times with fit_rotations on one thread, on the instruction set in force (MLSDEFORM_ISA
// chooses one), and prints that ISA with a checksum of the rotations.
//
//   fit_count float|double N [REPEATS]
//
// The matrices are uniform in [-1, 1] from a 64-bit linear congruential generator, so that every architecture
// fits the same inputs (std::normal_distribution's values go through libm, which differs between them).
#include <mlsdeform/mlsdeform.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

template <class T>
int run(std::size_t n, int repeats) {
  std::vector<T> H(9 * n), R(9 * n);
  std::uint64_t s = 0x9e3779b97f4a7c15ull;
  for (T& h : H) {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    h = T(double(s >> 11) * 0x1p-52 - 1.0);  // 53 bits: uniform in [-1, 1)
  }
  for (int r = 0; r < repeats; ++r)
    mlsdeform::fit_rotations(H.data(), R.data(), n, mlsdeform::RotationMethod::axis_angle, 1);
  double sum = 0;
  for (const T x : R) sum += double(x);
  std::printf("isa %s, %zu lanes, %zu fits x %d, checksum %.17g\n",
              std::string(mlsdeform::to_string(mlsdeform::active_isa())).c_str(), mlsdeform::simd_lanes<T>(), n,
              repeats, sum);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: fit_count float|double N [REPEATS]\n");
    return 2;
  }
  const std::string type = argv[1];
  const std::size_t n = std::strtoull(argv[2], nullptr, 10);
  const int repeats = argc > 3 ? std::atoi(argv[3]) : 1;
  if (type == "float") return run<float>(n, repeats);
  if (type == "double") return run<double>(n, repeats);
  std::fprintf(stderr, "fit_count: float or double, not '%s'\n", type.c_str());
  return 2;
}
