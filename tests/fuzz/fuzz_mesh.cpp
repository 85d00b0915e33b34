// libFuzzer targets for the mesh readers of the command-line tool (core/files/formats/): one binary, seven
// targets chosen by the environment variable FUZZ_MESH_FORMAT: "obj", "off" or "ply" (the input is the file's
// bytes), "gz" (the input is gzip data; its decompressed bytes are read as PLY, OFF or OBJ by their first
// bytes), or a splat format, "spz", "splat" or "compressed.ply" (core/files/formats/splat_codecs.hpp: what is
// read must encode as SPZ and compressed PLY, or be refused for a value those cannot hold, and read back). One
// binary because each build of it takes CI half a minute.
//
// Any input must either be read, and then give a mesh that keeps the documented invariants and writes and
// reads back bit for bit (positions, faces and every attribute kept: core/files/attributes.hpp), or be refused with
// InputError: a one-line message that names the file. Anything else (another exception, a crash, a sanitizer report, a
// hang) is a bug. Built with clang++ -fsanitize=fuzzer,address,undefined by tests/cli.cmake; the test suite runs each
// for a bounded number of inputs.
//
//   FUZZ_MESH_FORMAT=ply build/tests/fuzz_mesh -dict=tests/fuzz/mesh.dict NEW_CORPUS_DIR tests/fuzz/corpus_ply
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/mesh.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

namespace {

using namespace mlsdeform::files;

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

// Every value of `a`'s PLY layout is `b`'s, bit for bit; the vertex element's x, y, z aside, whose type is the
// output's coordinate type (compared as the mesh's vertices).
void check_same_layout(const PlyLayout& a, const PlyLayout& b) {
  if (a.elements.size() != b.elements.size() || a.header.size() != b.header.size())
    bug("PLY elements or comments differ after a round trip");
  for (std::size_t i = 0; i < a.header.size(); ++i)
    if (a.header[i].text != b.header[i].text || a.header[i].after != b.header[i].after)
      bug("a PLY comment differs after a round trip:", a.header[i].text);
  for (std::size_t e = 0; e < a.elements.size(); ++e) {
    const PlyElement &p = a.elements[e], &q = b.elements[e];
    if (p.name != q.name || p.count != q.count || p.properties.size() != q.properties.size())
      bug("a PLY element differs after a round trip:", p.name);
    const bool vertex = int(e) == a.vertex_element;
    for (std::size_t k = 0; k < p.properties.size(); ++k) {
      const bool xyz =
          vertex && (p.properties[k].name == "x" || p.properties[k].name == "y" || p.properties[k].name == "z");
      if (p.properties[k].name != q.properties[k].name || p.properties[k].list != q.properties[k].list ||
          (!xyz && p.properties[k].type != q.properties[k].type) ||
          p.properties[k].count_type != q.properties[k].count_type)
        bug("a PLY property differs after a round trip:", p.properties[k].name);
    }
    if (!vertex) {
      if (p.data != q.data) bug("PLY values differ after a round trip in element", p.name);
      continue;
    }
    for (std::size_t i = 0; i < p.count; ++i)
      for (std::size_t k = 0; k < p.properties.size(); ++k) {
        const std::string& n = p.properties[k].name;
        if (n == "x" || n == "y" || n == "z") continue;
        // A NaN's payload has no decimal text: an ASCII output keeps that it is a NaN.
        const double u = p.get(i, k), v = q.get(i, k);
        const bool same = std::isnan(u) ? std::isnan(v)
                                        : std::memcmp(p.data.data() + i * p.stride() + p.offset(k),
                                                      q.data.data() + i * q.stride() + q.offset(k),
                                                      size_of(p.properties[k].type)) == 0;
        if (!same) bug("a vertex property differs after a round trip:", n);
      }
  }
}

void check_same_extras(const MeshExtras& a, const MeshExtras& b) {
  if (a.ply.has_value() != b.ply.has_value() || a.obj.has_value() != b.obj.has_value() ||
      a.off.has_value() != b.off.has_value())
    bug("attributes of another format after a round trip");
  if (a.ply) check_same_layout(*a.ply, *b.ply);
  if (a.obj) {
    const ObjExtras &p = *a.obj, &q = *b.obj;
    if (p.normals_rewritten) {
      // Rewritten normals: each corner names one where it did, and they read back as written (shortest text).
      for (std::size_t c = 0; c < p.corner_normals.size(); ++c)
        if ((p.corner_normals[c] == ObjExtras::kNone) !=
            (c >= q.corner_normals.size() || q.corner_normals[c] == ObjExtras::kNone))
          bug("a corner's normal differs after a round trip");
    } else if (p.text != q.text || p.normals != q.normals || p.corner_normals != q.corner_normals) {
      bug("OBJ statements differ after a round trip");
    }
    if (p.vertex_tails.text != q.vertex_tails.text || p.vertex_tails.end != q.vertex_tails.end)
      bug("what follows a vertex's coordinates differs after a round trip");
  }
  if (a.off && (a.off->keyword != b.off->keyword || a.off->vertex_tails.text != b.off->vertex_tails.text ||
                a.off->vertex_tails.end != b.off->vertex_tails.end ||
                a.off->face_tails.text != b.off->face_tails.text || a.off->face_tails.end != b.off->face_tails.end))
    bug("OFF colours differ after a round trip");
}

// What is read is written and read back exactly (vertex order, faces, every coordinate bit, every attribute).
// A double mesh from a float PLY is written as float: its values are floats, so this holds for it too.
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
  check_same_extras(m.extras, back.extras);
}

// Normals transformed (here by a rotation about z and a shear: every vertex's linear part) are written where
// the file's were, and read back with every corner naming one where it did.
template <class T>
void check_transformed_round_trip(BasicMesh<T> m, const std::string& format, PlyEncoding ply) {
  if (!m.extras.has_normals()) return;
  std::vector<T> linear(std::size_t(m.vertex_count()) * 9);
  for (std::size_t i = 0; i < linear.size(); i += 9) {
    const T l[9] = {T(0.6), T(-0.8), T(0.5), T(0.8), T(0.6), T(0), T(0), T(0), T(1)};
    std::copy(l, l + 9, linear.begin() + std::ptrdiff_t(i));
  }
  transform_normals(m, linear.data());
  check_round_trip(m, format, ply);
}

std::string format_of(std::string_view text) {
  if (text.substr(0, 3) == "ply") return "ply";
  if (text.substr(0, 3) == "OFF") return "off";
  return "obj";
}

std::string g_target;  // "obj", "off", "ply", "gz", "spz", "splat" or "compressed.ply"

bool splat_target() { return g_target == "spz" || g_target == "splat" || g_target == "compressed.ply"; }

// A splat file read is the 3DGS layout's mesh; written as SPZ and as compressed PLY (lossy: compared in count
// only), unless refused, naming the output, for a value the format cannot hold.
void check_splats(std::string_view bytes) {
  const std::string name = "fuzz." + g_target;
  Mesh m;
  try {
    m = parse_mesh(*memory_source(bytes), "splat", name);
  } catch (const InputError& e) {
    check_message(e, name);
    return;
  }
  check_invariants(m);
  if (m.face_count() != 0 || !m.extras.ply) bug("a splat file read with faces or without its layout");
  for (const std::string out : {"round_trip.spz", "round_trip.compressed.ply"}) {
    std::string written;
    try {
      written = encode_mesh(m, out);
    } catch (const InputError& e) {
      check_message(e, out);
      continue;
    }
    try {
      const Mesh back = parse_mesh(*memory_source(written), "splat", out);
      if (back.vertex_count() != m.vertex_count()) bug("splats lost in a round trip through", out);
    } catch (const InputError& e) {
      bug("what was written does not read back:", e.what());
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* target = std::getenv("FUZZ_MESH_FORMAT");
  g_target = target ? target : "";
  if (g_target != "obj" && g_target != "off" && g_target != "ply" && g_target != "gz" && !splat_target())
    bug("set FUZZ_MESH_FORMAT to obj, off, ply, gz, spz, splat or compressed.ply; it is", "'" + g_target + "'");
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (splat_target()) {
    check_splats(bytes);
    return 0;
  }
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
    check_transformed_round_trip(m, format, ply);
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
