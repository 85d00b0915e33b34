// The program keeps what a mesh file carries besides positions and faces (core/files/attributes.hpp): every
// attribute read and written again holds the same value bit for bit, in every format and encoding (OBJ, OFF,
// PLY ASCII, binary little- and big-endian, each also gzip-compressed). The input files are built here, by a
// writer of the test's own (not the program's), with values of every PLY type drawn at random: for binary
// files any bit pattern (NaN payloads, subnormals, infinities) of the non-coordinate properties.
#include "tests/cli/cli_test_util.hpp"

#include "core/files/file_io.hpp"
#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <random>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

struct Prop {
  const char* name;
  PlyScalar type;
  bool list = false;
  PlyScalar count_type = PlyScalar::u8;
};
struct Elem {
  const char* name;
  std::size_t count;
  std::vector<Prop> props;
};

/// A PLY file with every property type, comments between declarations, a face element with extra properties
/// and two other elements (one with a list). Positions are floats of T's type in [-10, 10]; face corners
/// valid; every other value random: any bit pattern in a binary body, a finite number (or integer) in ASCII.
template <class T>
std::string random_ply(std::mt19937_64& rng, const std::string& format) {
  const PlyScalar c = std::is_same_v<T, float> ? PlyScalar::f32 : PlyScalar::f64;
  const std::vector<Elem> elems{
      {"vertex",
       40,
       {{"x", c},
        {"y", c},
        {"z", c},
        {"nx", PlyScalar::f32},
        {"ny", PlyScalar::f32},
        {"nz", PlyScalar::f32},
        {"red", PlyScalar::u8},
        {"green", PlyScalar::u8},
        {"blue", PlyScalar::u8},
        {"alpha", PlyScalar::u8},
        {"quality", PlyScalar::f64},
        {"label", PlyScalar::i32},
        {"flags", PlyScalar::u16},
        {"tiny", PlyScalar::i8},
        {"id", PlyScalar::u32},
        {"offset", PlyScalar::i16}}},
      {"face",
       30,
       {{"vertex_indices", PlyScalar::i32, true, PlyScalar::u8},
        {"red", PlyScalar::u8},
        {"weight", PlyScalar::f32},
        {"part", PlyScalar::i16}}},
      {"edge", 7, {{"vertex1", PlyScalar::i32}, {"vertex2", PlyScalar::i32}, {"crease", PlyScalar::f32}}},
      {"material", 3, {{"ids", PlyScalar::u16, true, PlyScalar::u16}, {"shine", PlyScalar::f64}}},
  };
  const bool binary = format != "ascii", big = format == "binary_big_endian";
  std::string h = "ply\nformat " + format + " 1.0\ncomment first\n";
  std::string body;
  for (const Elem& e : elems) {
    h += "element " + std::string(e.name) + " " + std::to_string(e.count) + "\n";
    if (e.name == std::string("face")) h += "obj_info between an element and its properties\n";
    for (const Prop& p : e.props)
      h += "property " + (p.list ? "list " + std::string(type_name(p.count_type)) + " " : std::string()) +
           std::string(type_name(p.type)) + " " + p.name + "\n";
  }
  h += "comment last\nend_header\n";
  auto put = [&](PlyScalar s, std::uint64_t bits, double ascii_value) {
    if (binary) {
      unsigned char b[8];
      std::memcpy(b, &bits, 8);  // the low size_of(s) bytes (little-endian machine)
      static_assert(std::endian::native == std::endian::little);
      const std::size_t n = size_of(s);
      if (big) std::reverse(b, b + n);
      body.append(reinterpret_cast<char*>(b), n);
      return;
    }
    char buf[64];
    char* end = s == PlyScalar::f32   ? std::to_chars(buf, buf + 64, float(ascii_value)).ptr
                : s == PlyScalar::f64 ? std::to_chars(buf, buf + 64, ascii_value).ptr
                                      : std::to_chars(buf, buf + 64, std::int64_t(ascii_value)).ptr;
    if (!body.empty() && body.back() != '\n') body += ' ';
    body.append(buf, end);
  };
  // Any bits but a NaN's: decimal text has no NaN payloads, so a binary NaN written as ASCII reads back as
  // another NaN (binary output keeps its bits; infinities, subnormals and -0 are kept in both).
  auto is_nan = [](PlyScalar s, std::uint64_t bits) {
    unsigned char b[8];
    std::memcpy(b, &bits, 8);
    return (s == PlyScalar::f32 || s == PlyScalar::f64) && std::isnan(ply_load(s, b));
  };
  auto random_value = [&](PlyScalar s) {
    std::uint64_t bits = rng();
    while (is_nan(s, bits)) bits = rng();
    double v;
    if (s == PlyScalar::f32 || s == PlyScalar::f64)
      v = std::uniform_real_distribution<double>(-1e6, 1e6)(rng) * std::pow(10.0, int(rng() % 20) - 10);
    else {
      unsigned char b[8];
      std::memcpy(b, &bits, 8);
      v = ply_load(s, b);  // the integer the bits are, so binary and ASCII draw the same kind of values
    }
    put(s, bits, v);
  };
  auto real = [&](PlyScalar s, double v) {
    std::uint64_t bits = 0;
    if (s == PlyScalar::f32) {
      const float f = float(v);
      std::memcpy(&bits, &f, 4);
    } else if (s == PlyScalar::f64) {
      std::memcpy(&bits, &v, 8);
    } else {
      unsigned char b[8] = {};
      ply_store(s, v, b);
      std::memcpy(&bits, b, 8);
    }
    put(s, bits, v);
  };
  for (const Elem& e : elems)
    for (std::size_t i = 0; i < e.count; ++i) {
      for (const Prop& p : e.props) {
        const std::string n = p.name;
        if (e.name == std::string("vertex") && (n == "x" || n == "y" || n == "z")) {
          real(p.type, std::uniform_real_distribution<double>(-10, 10)(rng));
        } else if (p.list) {
          const std::size_t k = 3 + rng() % 3;
          real(p.count_type, double(k));
          for (std::size_t j = 0; j < k; ++j)
            if (n == "vertex_indices")
              real(p.type, double(rng() % 40));
            else
              random_value(p.type);
        } else {
          random_value(p.type);
        }
      }
      if (!binary) body += '\n';
    }
  return h + body;
}

/// Every element, property, comment and value of `b` is `a`'s, bit for bit; positions too.
template <class T>
void require_same_ply(const BasicMesh<T>& a, const BasicMesh<T>& b) {
  REQUIRE(a.extras.ply);
  REQUIRE(b.extras.ply);
  const PlyLayout &x = *a.extras.ply, &y = *b.extras.ply;
  REQUIRE(x.elements.size() == y.elements.size());
  for (std::size_t e = 0; e < x.elements.size(); ++e) {
    const PlyElement &p = x.elements[e], &q = y.elements[e];
    INFO("element " << p.name);
    CHECK(p.name == q.name);
    CHECK(p.count == q.count);
    REQUIRE(p.properties.size() == q.properties.size());
    for (std::size_t k = 0; k < p.properties.size(); ++k) {
      CHECK(p.properties[k].name == q.properties[k].name);
      CHECK(p.properties[k].type == q.properties[k].type);
      CHECK(p.properties[k].list == q.properties[k].list);
      CHECK(p.properties[k].count_type == q.properties[k].count_type);
    }
    CHECK(p.data == q.data);  // every value's bytes, in the machine's order
  }
  REQUIRE(x.header.size() == y.header.size());
  for (std::size_t i = 0; i < x.header.size(); ++i) {
    CHECK(x.header[i].text == y.header[i].text);
    CHECK(x.header[i].after == y.header[i].after);
  }
  REQUIRE(a.vertex_count() == b.vertex_count());
  CHECK(std::memcmp(a.vertices.data(), b.vertices.data(), std::size_t(a.vertices.size()) * sizeof(T)) == 0);
  CHECK(a.face_indices == b.face_indices);
  CHECK(a.face_start == b.face_start);
}

template <class T>
void ply_round_trips(const char* name) {
  ScratchDir dir;
  const std::uint64_t seed = std::random_device{}();
  INFO(name << ", seed " << seed);
  std::mt19937_64 rng(seed);
  for (const std::string format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    INFO("input " << format);
    const std::string text = random_ply<T>(rng, format);
    for (const std::string in : {"in.ply", "in.ply.gz"}) {
      write_text(dir / in, is_gzip_path(in) ? gzip(text) : text);
      const BasicMesh<T> m = read_mesh<T>(dir / in);
      REQUIRE(m.extras.ply->elements.size() == 4);
      for (PlyEncoding enc : {PlyEncoding::binary, PlyEncoding::ascii})
        for (const std::string out : {"out.ply", "out.ply.gz"}) {
          INFO("read " << in << ", written " << out << (enc == PlyEncoding::ascii ? " (ascii)" : " (binary)"));
          write_mesh(m, dir / out, {true, enc});
          require_same_ply(m, read_mesh<T>(dir / out));
        }
    }
  }
}

}  // namespace

TEST_CASE("PLY: every element, property and value round-trips bit for bit", "[cli][attributes]") {
  ply_round_trips<float>("float");
  ply_round_trips<double>("double");
}

TEST_CASE("PLY: the accessor gives a property by name with its type", "[cli][attributes]") {
  ScratchDir dir;
  write_text(dir / "p.ply",
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
             "property uchar red\nproperty double f_dc_0\nend_header\n0 0 0 200 0.25\n1 2 3 7 -1e-300\n");
  const Mesh m = read_mesh(dir / "p.ply");
  const PlyElement& v = m.extras.ply->vertices();
  REQUIRE(v.find("f_dc_0") == 4);
  CHECK(v.find("nope") == -1);
  CHECK(v.properties[3].type == PlyScalar::u8);
  CHECK(v.get(0, 3) == 200);
  CHECK(v.get(1, 4) == -1e-300);
  PlyElement copy = v;
  copy.set(1, 3, 300.0);  // clamped to uchar's range
  CHECK(copy.get(1, 3) == 255);
}

TEST_CASE("OBJ: every statement and vertex colour is written back as read", "[cli][attributes]") {
  // Numbers in their shortest texts, so that the v lines the writer prints are the file's own.
  const std::string body =
      "mtllib scene.mtl\n"
      "o thing\n"
      "v 0 0 0 1 0 0\n"
      "v 1 0 0 0 1 0\n"
      "v 1 1 0 0 0 1 # a comment after a colour\n"
      "v 0 1 0.5\n"
      "\n"
      "vt 0 0\nvt 1 0\nvt 1 1\n"
      "vn 0 0 1\nvn 0.6 0 0.8\n"
      "g side\nusemtl red\ns 1\n"
      "f 1/1/1 2/2/1 3/3/2\n"
      "f 1//1 3//2 4//2\n"
      "s off\n"
      "f 1/1 3/3 4/2\n"
      "f -4 -3 -2\n"
      "l 1 2\np 4\n"
      "# the end\n"
      "v 2 2 2\n";
  ScratchDir dir;
  for (const std::string name : {"in.obj", "in.obj.gz"}) {
    write_text(dir / name, is_gzip_path(name) ? gzip(body) : body);
    const Mesh m = read_mesh(dir / name);
    CHECK(m.vertex_count() == 5);
    CHECK(m.face_count() == 4);
    const std::string out = is_gzip_path(name) ? "out.obj.gz" : "out.obj";
    write_mesh(m, dir / out, {true});
    const std::string text =
        is_gzip_path(out) ? gunzip(cli_test::read_text(dir / out), out) : cli_test::read_text(dir / out);
    const std::size_t first = text.find('\n') + 1;
    CHECK(text.substr(0, first).rfind("# written by mlsdeform ", 0) == 0);
    CHECK(text.substr(first) == body);
    // Read again: the same statements (the stamp is not kept twice).
    const Mesh back = read_mesh(dir / out);
    CHECK(back.extras.obj->text == m.extras.obj->text);
    CHECK(back.extras.obj->normals == m.extras.obj->normals);
    CHECK(back.extras.obj->corner_normals == m.extras.obj->corner_normals);
  }
}

TEST_CASE("OFF: vertex and face colours are written back as read", "[cli][attributes]") {
  const std::string counts_on = "3 2 0\n";
  const std::string body = "0 0 0 255 0 0\n1 0 0 0.5 0.5 0.5 1\n0 1 0\n3 0 1 2 10 20 30\n3 2 1 0\n";
  ScratchDir dir;
  for (const std::string keyword : {"OFF", "COFF"})
    for (const std::string name : {"in.off", "in.off.gz"}) {
      const std::string file = keyword + "\n" + counts_on + body;
      write_text(dir / name, is_gzip_path(name) ? gzip(file) : file);
      const Mesh m = read_mesh(dir / name);
      write_mesh(m, dir / name + ".off", {true});
      const std::string text = cli_test::read_text(dir / name + ".off");
      CHECK(text.rfind(keyword + "\n# written by mlsdeform ", 0) == 0);
      CHECK(text.substr(text.find('\n', keyword.size() + 1) + 1) == counts_on + body);
    }
}
