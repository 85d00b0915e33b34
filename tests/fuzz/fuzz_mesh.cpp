// libFuzzer targets for the mesh readers of the command-line tool (tools/cli/formats/): one binary, four
// targets chosen by the environment variable FUZZ_MESH_FORMAT: "obj", "off" or "ply" (the input is the file's
// bytes), or "gz" (the input is gzip data; its decompressed bytes are read as PLY, OFF or OBJ by their first
// bytes). One binary because each build of it takes CI half a minute.
//
// Any input must either be read, and then give a mesh that keeps the documented invariants and writes and
// reads back bit for bit, or be refused with InputError: a one-line message that names the file. Anything
// else (another exception, a crash, a sanitizer report, a hang) is a bug. Built with clang++
// -fsanitize=fuzzer,address,undefined by tests/cli.cmake; the test suite runs each for a bounded number of inputs.
//
//   FUZZ_MESH_FORMAT=ply build/tests/fuzz_mesh -dict=tests/fuzz/mesh.dict NEW_CORPUS_DIR tests/fuzz/corpus_ply
#include "tools/cli/error.hpp"
#include "tools/cli/file_io.hpp"
#include "tools/cli/mesh.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

namespace {

using namespace mlsdeform::cli;

[[noreturn]] void bug(const char* what, const std::string& detail = {}) {
  std::fprintf(stderr, "fuzz_mesh: %s %s\n", what, detail.c_str());
  std::abort();
}

void check_message(const InputError& e, const std::string& name) {
  const std::string m = e.what();
  if (m.rfind(name + ": ", 0) != 0) bug("message does not start with the file name:", m);
  if (m.find('\n') != std::string::npos || m.find('\r') != std::string::npos) bug("message is not one line:", m);
}

template <class T>
void check_invariants(const BasicMesh<T>& m) {
  const auto nv = std::uint64_t(m.vertex_count());
  if (nv == 0) bug("a mesh with no vertices was accepted");
  if (!m.vertices.allFinite()) bug("a non-finite coordinate was accepted");
  if (m.face_start.empty() || m.face_start.front() != 0 || m.face_start.back() != m.face_indices.size())
    bug("face_start does not frame face_indices");
  for (std::size_t f = 0; f + 1 < m.face_start.size(); ++f)
    if (m.face_start[f + 1] < m.face_start[f] + 3) bug("a face with fewer than 3 vertices, face", std::to_string(f));
  for (const std::uint32_t i : m.face_indices)
    if (i >= nv) bug("a vertex index out of range:", std::to_string(i));
}

// What is read is written and read back exactly (vertex order, faces, every coordinate bit). A double mesh
// from a float PLY is written as float: its values are floats, so this holds for it too.
template <class T>
void check_round_trip(const BasicMesh<T>& m, const std::string& format, PlyEncoding ply) {
  const std::string name = "round_trip." + format;
  const std::string bytes = encode_mesh(m, name, {false, ply});
  const auto source = memory_source(bytes);
  BasicMesh<T> back;
  try {
    back = parse_mesh<T>(*source, format, name);
  } catch (const InputError& e) {
    bug("what was written does not read back:", e.what());
  }
  if (back.vertices.rows() != m.vertices.rows() ||
      std::memcmp(back.vertices.data(), m.vertices.data(), std::size_t(m.vertices.size()) * sizeof(T)) != 0)
    bug("vertices differ after a round trip");
  if (back.face_start != m.face_start || back.face_indices != m.face_indices) bug("faces differ after a round trip");
}

std::string format_of(std::string_view text) {
  if (text.substr(0, 3) == "ply") return "ply";
  if (text.substr(0, 3) == "OFF") return "off";
  return "obj";
}

std::string g_target;  // "obj", "off", "ply" or "gz"

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* target = std::getenv("FUZZ_MESH_FORMAT");
  g_target = target ? target : "";
  if (g_target != "obj" && g_target != "off" && g_target != "ply" && g_target != "gz")
    bug("set FUZZ_MESH_FORMAT to obj, off, ply or gz; it is", "'" + g_target + "'");
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (g_target == "gz") {
    const std::string name = "fuzz.gz";
    try {
      // A small limit: a few KiB of gzip can expand to gigabytes, which must be refused, not allocated.
      auto source = gunzip_source(memory_source(bytes), name, std::size_t(1) << 20);
      char head[3] = {};
      const std::string format = format_of(std::string_view(head, source->read(head, 3)));
      source->rewind();
      check_invariants(parse_mesh(*source, format, name));
    } catch (const InputError& e) {
      check_message(e, name);
    }
    return 0;
  }
  const std::string& format = g_target;
  const std::string name = "fuzz." + format;
  const PlyEncoding ply = size % 2 ? PlyEncoding::ascii : PlyEncoding::binary;
  // Read as float (--precision float) and as double: what float reads, double reads too (its range holds
  // float's), with the same vertex count and faces.
  Mesh m;
  bool as_float = true;
  try {
    const auto source = memory_source(bytes);
    m = parse_mesh(*source, format, name);
  } catch (const InputError& e) {
    check_message(e, name);
    as_float = false;
  }
  if (as_float) {
    check_invariants(m);
    check_round_trip(m, format, ply);
  }
  BasicMesh<double> d;
  try {
    const auto source = memory_source(bytes);
    d = parse_mesh<double>(*source, format, name);
  } catch (const InputError& e) {
    check_message(e, name);
    if (as_float) bug("read as float but refused as double:", e.what());
    return 0;
  }
  check_invariants(d);
  if (as_float &&
      (d.vertex_count() != m.vertex_count() || d.face_start != m.face_start || d.face_indices != m.face_indices))
    bug("float and double read different meshes");
  check_round_trip(d, format, ply);
  return 0;
}
