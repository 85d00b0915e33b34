// The C++ library's own result for the Python tests' bitwise comparison (python/tests/test_mlsdeform.py):
//   mlsdeform_py_reference f|d rigid|similarity|affine u paper_constant|exact_integral n k s in out
// `in` holds raw T values, row-major: V (n x 3), P (k x 3), A, B (s x 3 each), then the moved Q, C, D;
// `out` receives the deformed vertices (n x 3, row-major) from Deformer<T>::deform.
#include <mlsdeform/mlsdeform.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace {

template <class T>
mlsdeform::Points<T> read_points(std::ifstream& in, long rows) {
  std::vector<T> buf(static_cast<std::size_t>(3 * rows));
  in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(buf.size() * sizeof(T)));
  mlsdeform::Points<T> p(rows, 3);
  for (long i = 0; i < rows; ++i)
    for (int c = 0; c < 3; ++c) p(i, c) = buf[static_cast<std::size_t>(3 * i + c)];
  return p;
}

template <class T>
int run(char** argv) {
  using namespace mlsdeform;
  Options o;
  const std::string tr = argv[2];
  o.transform = tr == "rigid" ? Transform::rigid : tr == "similarity" ? Transform::similarity : Transform::affine;
  o.weight_exponent = std::atof(argv[3]);
  o.segment_weight =
      std::string(argv[4]) == "exact_integral" ? SegmentWeight::exact_integral : SegmentWeight::paper_constant;
  const long n = std::atol(argv[5]), k = std::atol(argv[6]), s = std::atol(argv[7]);
  std::ifstream in(argv[8], std::ios::binary);
  const Points<T> V = read_points<T>(in, n);
  Handles<T> rest, moved;
  rest.points = read_points<T>(in, k);
  rest.segment_a = read_points<T>(in, s);
  rest.segment_b = read_points<T>(in, s);
  moved.points = read_points<T>(in, k);
  moved.segment_a = read_points<T>(in, s);
  moved.segment_b = read_points<T>(in, s);
  if (!in) {
    std::fprintf(stderr, "reference: short input\n");
    return 2;
  }
  PointsRowMajor<T> out(n, 3);
  Deformer<T>(V, rest, o).deform(moved, InterleavedView<T>(out.data(), n, 3));
  std::ofstream(argv[9], std::ios::binary)
      .write(reinterpret_cast<const char*>(out.data()), static_cast<std::streamsize>(out.size() * sizeof(T)));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 10) {
    std::fprintf(stderr, "usage: %s f|d transform u segment_weight n k s in out\n", argv[0]);
    return 2;
  }
  return argv[1][0] == 'f' ? run<float>(argv) : run<double>(argv);
}
