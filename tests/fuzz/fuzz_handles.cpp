// libFuzzer target for the handles-file reader of the command-line tool (core/files/handles/).
//
// Any input must either parse, and then resolve or fail to resolve against a small mesh, or be rejected with
// InputError: a one-line message that names the file. Anything else (another exception, a crash, a sanitizer
// report, a resolved value that breaks the documented invariants) is a bug. Built with clang++
// -fsanitize=fuzzer,address,undefined by tests/cli.cmake; the test suite runs it for 20000 inputs.
//
//   build/tests/fuzz_handles -dict=tests/fuzz/handles.dict NEW_CORPUS_DIR tests/fuzz/corpus
#include "core/files/handles_file.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

using namespace mlsdeform;
using namespace mlsdeform::files;

[[noreturn]] void bug(const char* what, const std::string& detail = {}) {
  std::fprintf(stderr, "fuzz_handles: %s %s\n", what, detail.c_str());
  std::abort();
}

void check_message(const InputError& e) {
  const std::string m = e.what();
  if (m.rfind("fuzz.json: ", 0) != 0) bug("message does not start with the file name:", m);
  if (m.find('\n') != std::string::npos || m.find('\r') != std::string::npos) bug("message is not one line:", m);
}

template <class T>
void check_resolved(const HandlesFile& h, const PointsRowMajor<float>& vertices) {
  ResolvedHandles<T> r;
  try {
    r = resolve_handles<T>(h, vertices);
  } catch (const InputError& e) {
    check_message(e);
    return;
  }
  const auto k = Eigen::Index(h.points.size()), s = Eigen::Index(h.segments.size());
  if (r.rest.points.rows() != k || r.rest.segment_a.rows() != s || r.rest.segment_b.rows() != s)
    bug("rest handle counts");
  if (!r.rest.points.allFinite() || !r.rest.segment_a.allFinite() || !r.rest.segment_b.allFinite())
    bug("non-finite rest handle");
  for (Eigen::Index i = 0; i < s; ++i)
    if (r.rest.segment_a.row(i) == r.rest.segment_b.row(i)) bug("zero-length rest segment accepted");
  if (r.frames.size() != (h.animated() ? h.frames.size() : 1)) bug("frame count");
  for (const auto& f : r.frames) {
    if (f.points.rows() != k || f.segment_a.rows() != s || f.segment_b.rows() != s) bug("frame handle counts");
    if (!f.points.allFinite() || !f.segment_a.allFinite() || !f.segment_b.allFinite()) bug("non-finite target");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const PointsRowMajor<float> vertices = [] {
    PointsRowMajor<float> v(4, 3);
    v << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    return v;
  }();
  HandlesFile h;
  try {
    h = parse_handles(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json");
  } catch (const InputError& e) {
    check_message(e);
    return 0;
  }
  if (h.points.empty() && h.segments.empty()) bug("a file without handles was accepted");
  for (const auto& f : h.frames)
    if (f.points.size() != h.points.size() || f.segments.size() != h.segments.size())
      bug("a frame with mismatched counts");
  check_resolved<float>(h, vertices);
  check_resolved<double>(h, vertices);
  return 0;
}
