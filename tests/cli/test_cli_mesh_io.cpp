// Mesh reading and writing of the command-line tool (core/files/mesh_*.cpp): every format round-trips vertex
// count, faces and coordinates, the file's vertex order is kept, and malformed files fail with a message
// naming the file.
#include "tests/cli/cli_test_util.hpp"
#include "tests/cli/malformed_meshes.hpp"

#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

using namespace mlsdeform;
using namespace mlsdeform::files;
using cli_test::ScratchDir;
using cli_test::write_text;

namespace {

// Polygons of 3, 4 and 5 corners, coordinates across magnitudes and signs (and -0), and a vertex no face uses.
Mesh sample_mesh() {
  Mesh m;
  m.vertices.resize(9, 3);
  m.vertices << 0.0f, 0.0f, 0.0f,          //
      1.0f, -0.0f, 0.1f,                   //
      1.5f, 1.25f, -3.0e-3f,               //
      0.3333333f, 2.7182817f, 3.1415927f,  //
      -12345.678f, 0.000123f, 42.0f,       //
      1.0e6f, -7.5f, 0.0009765625f,        //
      -0.2f, 0.7f, 1.9f,                   //
      5.0f, 5.0f, 5.0f,                    // unused by any face
      0.123456789f, -98.7654f, 3.0e-4f;
  m.add_face({0, 1, 2});
  m.add_face({0, 2, 3, 6});
  m.add_face({1, 4, 5, 8, 2});
  m.add_face({6, 3, 8});
  return m;
}

// Random coordinates in [-1000, 1000] with 1e-4 <= |x| (the writers' shortest texts read back exactly, see
// TextOut in core/files/formats/writer.hpp), on a triangle strip.
Mesh random_mesh(std::uint32_t seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> mag(-4.0f, 3.0f);
  Mesh m;
  m.vertices.resize(n, 3);
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) m.vertices(i, k) = (rng() & 1 ? -1.0f : 1.0f) * std::pow(10.0f, mag(rng));
  for (int i = 0; i + 2 < n; ++i) m.add_face({std::uint32_t(i), std::uint32_t(i + 1), std::uint32_t(i + 2)});
  return m;
}

void require_same(const Mesh& a, const Mesh& b) {
  REQUIRE(a.vertex_count() == b.vertex_count());
  REQUIRE(a.face_start == b.face_start);
  REQUIRE(a.face_indices == b.face_indices);
  // Bit for bit: binary PLY stores the floats themselves; the text formats write texts that read back exactly.
  for (Eigen::Index i = 0; i < a.vertex_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      INFO("vertex " << i << " coordinate " << k << ": wrote " << a.vertices(i, k) << ", read " << b.vertices(i, k));
      REQUIRE(std::memcmp(&a.vertices(i, k), &b.vertices(i, k), sizeof(float)) == 0);
    }
}

const char* formats[] = {"obj", "off", "ply", "obj.gz", "off.gz", "ply.gz"};

}  // namespace

TEST_CASE("every format round-trips vertex count, faces and coordinates", "[cli][mesh]") {
  ScratchDir dir;
  const std::uint32_t seed = std::random_device{}();
  INFO("random mesh seed " << seed);
  for (const Mesh& m : {sample_mesh(), random_mesh(seed, 500)}) {
    for (const char* f : formats) {
      for (PlyEncoding enc : {PlyEncoding::binary, PlyEncoding::ascii}) {
        if (enc == PlyEncoding::ascii && std::strncmp(f, "ply", 3) != 0) continue;
        for (NormalsOut normals : {NormalsOut::computed, NormalsOut::input}) {
          const std::string path = dir / (std::string("m.") + f);
          INFO("format " << f << (enc == PlyEncoding::ascii ? " (ascii)" : "")
                         << (normals == NormalsOut::computed ? " with normals" : ""));
          write_mesh(m, path, {/*force=*/true, enc, normals});
          require_same(m, read_mesh(path));
        }
      }
    }
  }
}

TEST_CASE("double meshes round-trip in every format bit for bit", "[cli][mesh][precision]") {
  // Coordinates over the whole range of double (random exponents, full 53-bit mantissas, subnormals, the
  // extremes), written by the writers' shortest texts or as PLY doubles and read back as doubles.
  ScratchDir dir;
  const std::uint32_t seed = std::random_device{}();
  INFO("seed " << seed);
  std::mt19937_64 rng(seed);
  BasicMesh<double> m;
  m.vertices.resize(300, 3);
  std::uniform_int_distribution<int> exponent(-1074, 1023);
  for (Eigen::Index i = 0; i < m.vertex_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      const double mantissa = std::uniform_real_distribution<double>(1, 2)(rng);
      m.vertices(i, k) = (rng() & 1 ? -1 : 1) * std::ldexp(mantissa, exponent(rng));
    }
  m.vertices.row(0) << std::numeric_limits<double>::max(), std::numeric_limits<double>::denorm_min(), -0.0;
  m.vertices.row(1) << std::numeric_limits<double>::min(), -std::numeric_limits<double>::max(), 0.1;
  for (std::uint32_t i = 0; i + 2 < 300; ++i) m.add_face({i, i + 1, i + 2});
  for (const char* f : formats)
    for (PlyEncoding enc : {PlyEncoding::binary, PlyEncoding::ascii}) {
      if (enc == PlyEncoding::ascii && std::strncmp(f, "ply", 3) != 0) continue;
      const std::string path = dir / (std::string("m.") + f);
      INFO("format " << f << (enc == PlyEncoding::ascii ? " (ascii)" : ""));
      write_mesh(m, path, {true, enc});
      const BasicMesh<double> back = read_mesh<double>(path);
      REQUIRE(back.vertex_count() == m.vertex_count());
      CHECK(back.face_indices == m.face_indices);
      CHECK(std::memcmp(back.vertices.data(), m.vertices.data(), std::size_t(m.vertices.size()) * sizeof(double)) == 0);
      if (std::strncmp(f, "ply", 3) == 0) CHECK(back.stored_type == CoordinateType::float64);
      // Read as float, the same file is refused where a coordinate is beyond float's range, saying so.
      CHECK_THROWS_WITH(read_mesh<float>(path), Catch::Matchers::ContainsSubstring("range of"));
    }
}

// Integer coordinates: a double mesh keeps every int and uint of 32 bits (float's 24-bit significand would
// round 2^24 + 1), so its PLY output is double; 8- and 16-bit integers fit in float, so it stays float.
TEST_CASE("integer PLY coordinates are written back in a type that holds them", "[cli][mesh]") {
  ScratchDir dir;
  struct Case {
    const char* type;
    const char* values;  // x y z of the first vertex
    CoordinateType expected;
  };
  for (const Case& c :
       {Case{"int", "16777217 -2147483648 2147483647", CoordinateType::float64},
        Case{"uint", "16777217 4294967295 0", CoordinateType::float64},
        Case{"short", "-32768 32767 1", CoordinateType::float32}, Case{"uchar", "255 0 1", CoordinateType::float32}}) {
    INFO(c.type);
    const std::string t = c.type;
    write_text(dir / "in.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty " + t + " x\nproperty " + t +
                                   " y\nproperty " + t +
                                   " z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                   "end_header\n" +
                                   c.values + "\n0 1 0\n1 0 0\n3 0 1 2\n");
    const BasicMesh<double> m = read_mesh<double>(dir / "in.ply");
    CHECK(m.stored_type == c.expected);
    for (PlyEncoding enc : {PlyEncoding::binary, PlyEncoding::ascii}) {
      write_mesh(m, dir / "out.ply", {true, enc});
      const BasicMesh<double> back = read_mesh<double>(dir / "out.ply");
      CHECK(std::memcmp(back.vertices.data(), m.vertices.data(), std::size_t(m.vertices.size()) * sizeof(double)) == 0);
    }
  }
}

TEST_CASE("written files are what their extension says", "[cli][mesh]") {
  ScratchDir dir;
  const Mesh m = sample_mesh();
  write_mesh(m, dir / "a.ply", {});
  CHECK(cli_test::read_text(dir / "a.ply").rfind("ply\nformat binary_little_endian 1.0\n", 0) == 0);
  write_mesh(m, dir / "b.ply", {false, PlyEncoding::ascii});
  CHECK(cli_test::read_text(dir / "b.ply").rfind("ply\nformat ascii 1.0\n", 0) == 0);
  write_mesh(m, dir / "c.off", {});
  CHECK(cli_test::read_text(dir / "c.off").rfind("OFF\n", 0) == 0);
  write_mesh(m, dir / "d.obj", {});
  const std::string plain = cli_test::read_text(dir / "d.obj");
  CHECK(plain.find("\nvn ") == std::string::npos);            // no normals invented
  CHECK(plain.find("\nf 2 5 6 9 3\n") != std::string::npos);  // the pentagon, 1-based
  write_mesh(m, dir / "d.obj", {true, PlyEncoding::binary, NormalsOut::computed});
  const std::string obj = cli_test::read_text(dir / "d.obj");
  CHECK(obj.find("\nvn ") != std::string::npos);                           // normals computed on request
  CHECK(obj.find("\nf 2//2 5//5 6//6 9//9 3//3\n") != std::string::npos);  // the pentagon, 1-based
  const std::string gz = cli_test::read_text((write_mesh(m, dir / "e.ply.gz", {}), dir / "e.ply.gz"));
  REQUIRE(gz.size() > 2);
  CHECK((unsigned char)gz[0] == 0x1f);  // gzip magic
  CHECK((unsigned char)gz[1] == 0x8b);
}

TEST_CASE("recomputed normals are unit area-weighted face normals", "[cli][mesh]") {
  Mesh m;  // a unit square in the z = 0 plane, counter-clockwise seen from +z, and a lone vertex
  m.vertices.resize(5, 3);
  m.vertices << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 3, 3, 3;
  m.add_face({0, 1, 2, 3});
  const auto n = vertex_normals(m);
  for (int i = 0; i < 4; ++i) CHECK((n.row(i) - Eigen::RowVector3f(0, 0, 1)).norm() < 1e-6f);
  CHECK(n.row(4).norm() == 0.0f);
}

TEST_CASE("OBJ keeps the file's vertex order, unused vertices and polygons", "[cli][mesh]") {
  ScratchDir dir;
  // Faces list the vertices out of order, with texture and normal indices, a negative (relative) index, a
  // group, a comment, and a vertex (5) no face uses: the file's numbering is kept.
  write_text(dir / "a.obj",
             "# test\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 5 5 5\nv 0 0 1\nvt 0 0\nvn 0 0 1\n"
             "g one\nf 3/1/1 4/1/1 1/1/1 2/1/1\ng two\nf 1//1 2//1 -1//1\n");
  const Mesh m = read_mesh(dir / "a.obj");
  REQUIRE(m.vertex_count() == 6);
  CHECK(m.vertices.row(4) == Eigen::RowVector3f(5, 5, 5));
  CHECK(m.vertices.row(5) == Eigen::RowVector3f(0, 0, 1));
  REQUIRE(m.face_count() == 2);
  CHECK(std::vector<std::uint32_t>(m.face_indices.begin(), m.face_indices.begin() + 4) ==
        std::vector<std::uint32_t>{2, 3, 0, 1});
  CHECK(std::vector<std::uint32_t>(m.face_indices.begin() + 4, m.face_indices.end()) ==
        std::vector<std::uint32_t>{0, 1, 5});
}

TEST_CASE("OFF and PLY keep the file's vertex order", "[cli][mesh]") {
  ScratchDir dir;
  write_text(dir / "a.off", "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n5 5 5\n4 2 3 0 1\n3 0 1 2\n");
  write_text(dir / "a.ply",
             "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n5 5 5\n"
             "4 2 3 0 1\n3 0 1 2\n");
  for (const char* f : {"a.off", "a.ply"}) {
    INFO(f);
    const Mesh m = read_mesh(dir / f);
    REQUIRE(m.vertex_count() == 5);
    CHECK(m.vertices.row(4) == Eigen::RowVector3f(5, 5, 5));
    CHECK(m.face_indices == std::vector<std::uint32_t>{2, 3, 0, 1, 0, 1, 2});
  }
}

TEST_CASE("the bundled mesh reads with the file's counts", "[cli][mesh]") {
  const Mesh m = read_mesh(MLSDEFORM_SOURCE_DIR "/data/human_man.obj");
  CHECK(m.vertex_count() == 6890);
  CHECK(m.face_count() == 13776);
  // The file's first `v` line, correctly rounded to float.
  CHECK(m.vertices.row(0) == Eigen::RowVector3f(0.042626f, 1.716077f, 0.104022f));
}

namespace {

// read_mesh must throw InputError whose message starts with the file name and contains `expected`.
void require_read_error(const std::string& path, const std::string& expected) {
  INFO("reading " << path);
  try {
    read_mesh(path);
    FAIL("no error");
  } catch (const InputError& e) {
    const std::string what = e.what();
    INFO("message: " << what);
    CHECK(what.rfind(path + ": ", 0) == 0);
    CHECK(what.find(expected) != std::string::npos);
    CHECK(what.find('\n') == std::string::npos);
  }
}

}  // namespace

TEST_CASE("malformed and missing mesh files are reported with the file and the problem", "[cli][mesh][errors]") {
  ScratchDir dir;
  require_read_error(dir / "missing.obj", "cannot open: No such file or directory");
  std::filesystem::create_directory(dir / "folder.obj");
  require_read_error(dir / "folder.obj", "is a directory");
  write_text(dir / "mesh.xyz", "1 2 3\n");
  require_read_error(dir / "mesh.xyz", "unknown mesh format '.xyz'");
  write_text(dir / "empty.off", "");
  require_read_error(dir / "empty.off", "empty file");
  write_text(dir / "garbage.ply", "this is not a ply file\n");
  require_read_error(dir / "garbage.ply", "line 1: malformed PLY: the first line is not 'ply'");
  write_text(dir / "noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  require_read_error(dir / "noend.ply", "malformed PLY: the header has no end_header line");
  write_text(dir / "garbage.off", "OFF\nthree two one\n");
  require_read_error(dir / "garbage.off", "line 2: malformed OFF: expected 'vertices faces edges' counts");
  write_text(dir / "nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
  require_read_error(dir / "nan.obj", "line 3: vertex 2 has a non-finite coordinate");
  write_text(dir / "inf.off", "OFF\n3 1 0\n0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n");
  require_read_error(dir / "inf.off", "vertex 1 has a non-finite coordinate");
  write_text(dir / "index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  require_read_error(dir / "index.obj", "line 4: vertex index 7 is out of range (3 vertices)");
  write_text(dir / "index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n");
  require_read_error(dir / "index.off", "line 6: face 0 refers to vertex 9, but there are only 3");
  write_text(dir / "index.ply",
             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
             "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  require_read_error(dir / "index.ply", "face 0 refers to vertex 7, but there are only 3");
  write_text(dir / "count.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  require_read_error(dir / "count.obj",
                     "line 1: a vertex needs 3 coordinates (x y z, optionally w, or x y z r g b), found 2");
  // A binary PLY cut short in its vertex data.
  Mesh m;
  m.vertices.resize(3, 3);
  m.vertices << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  m.add_face({0, 1, 2});
  std::string ply = encode_mesh(m, "x.ply");
  write_text(dir / "truncated.ply", ply.substr(0, ply.size() - 30));
  require_read_error(dir / "truncated.ply", "the header promises 3 vertex elements, but only");
  std::string ascii = encode_mesh(m, "x.ply", {false, PlyEncoding::ascii});
  write_text(dir / "truncated_ascii.ply", ascii.substr(0, ascii.size() - 12));
  require_read_error(dir / "truncated_ascii.ply", "the header promises 3 vertex elements, but only");
  // gzip: not gzip at all, and cut short.
  write_text(dir / "plain.ply.gz", ply);
  require_read_error(dir / "plain.ply.gz", "corrupt gzip data");
  const std::string gz = encode_mesh(m, "x.ply.gz");
  write_text(dir / "short.ply.gz", gz.substr(0, gz.size() / 2));
  require_read_error(dir / "short.ply.gz", "truncated gzip data");
  write_text(dir / "nothing.obj", "# no vertices\n");
  require_read_error(dir / "nothing.obj", "no vertices");
}

TEST_CASE("writing is all or nothing and does not overwrite without force", "[cli][mesh][errors]") {
  ScratchDir dir;
  const Mesh m = sample_mesh();
  write_mesh(m, dir / "a.obj", {});
  const std::string before = cli_test::read_text(dir / "a.obj");
  try {
    write_mesh(random_mesh(1, 10), dir / "a.obj", {});
    FAIL("overwrote without force");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) == dir / "a.obj" + ": already exists (use --force to overwrite)");
  }
  CHECK(cli_test::read_text(dir / "a.obj") == before);
  write_mesh(random_mesh(1, 10), dir / "a.obj", {/*force=*/true});
  CHECK(cli_test::read_text(dir / "a.obj") != before);
  CHECK(dir.files() == std::vector<std::string>{"a.obj"});  // no temporary left

  // An output whose folder does not exist, or is a file.
  for (const std::string& bad : {dir / "no/such/folder/b.obj", dir / "a.obj/b.obj"}) {
    INFO(bad);
    CHECK_THROWS_AS(check_output_path(bad, false), InputError);
    CHECK_THROWS_WITH(write_mesh(m, bad, {}), Catch::Matchers::StartsWith(bad + ": cannot write"));
  }
  CHECK_THROWS_WITH(write_mesh(m, dir / "c.stl", {}),
                    Catch::Matchers::ContainsSubstring("unknown output format '.stl'"));
  CHECK(dir.files() == std::vector<std::string>{"a.obj"});
}

TEST_CASE("error messages stay one line whatever the file name or contents", "[cli][errors]") {
  CHECK(std::string(InputError("a\nb.obj", "bad\r", "line 2").what()) == "a\\x0ab.obj: line 2: bad\\x0d");
  CHECK(std::string(InputError("\x7f.ply", "x").what()) == "\\x7f.ply: x");
  CHECK(std::string(InputError("caf\xc3\xa9.obj", "x").what()) == "caf\xc3\xa9.obj: x");  // UTF-8 names as they are
}

TEST_CASE("gzip round trip, including concatenated members", "[cli][mesh]") {
  const std::string text = "hello, mesh\n";
  CHECK(gunzip(gzip(text), "t") == text);
  CHECK(gunzip(gzip(text) + gzip(text), "t") == text + text);
  CHECK(gunzip(gzip(""), "t").empty());
}

TEST_CASE("strict readers: the malformed files that used to pass are refused", "[cli][mesh][errors]") {
  ScratchDir dir;
  for (const auto& c : cli_test::malformed_meshes()) {
    write_text(dir / c.name, c.bytes);
    require_read_error(dir / c.name, c.expected);
  }
  const Mesh cube = cli_test::cube_mesh();
  // Both binary byte orders and ASCII read back bit for bit; big-endian written by hand.
  for (const char* name : {"c.ply", "c_ascii.ply"}) {
    const PlyEncoding enc = std::string(name) == "c.ply" ? PlyEncoding::binary : PlyEncoding::ascii;
    write_text(dir / name, encode_mesh(cube, name, {false, enc}));
    const Mesh m = read_mesh(dir / name);
    CHECK(m.vertices == cube.vertices);
    CHECK(m.face_indices == cube.face_indices);
  }
  std::string be =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  auto put_be = [&](const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = n; i-- > 0;) be.push_back(char(b[i]));
  };
  const float xyz[9] = {0, 0, 0, 1.5f, 0, 0, 0, -2.25f, 0};
  for (float v : xyz) put_be(&v, 4);
  be.push_back(char(3));
  for (std::int32_t i : {0, 1, 2}) put_be(&i, 4);
  write_text(dir / "be.ply", be);
  const Mesh m = read_mesh(dir / "be.ply");
  CHECK(m.vertices.row(1) == Eigen::RowVector3f(1.5f, 0, 0));
  CHECK(m.vertices.row(2) == Eigen::RowVector3f(0, -2.25f, 0));
  CHECK(m.face_indices == std::vector<std::uint32_t>{0, 1, 2});
}

TEST_CASE("gzip input is refused past the size limit while decompressing", "[cli][mesh][errors]") {
  ScratchDir dir;
  // 64 MiB of zeros compress to about 64 KiB; with a 16 MiB limit the reader stops at 16 MiB.
  write_text(dir / "zeros.obj.gz", gzip(std::string(std::size_t(64) << 20, '0')));
  try {
    read_mesh(dir / "zeros.obj.gz", std::size_t(16) << 20);
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find(
              "decompresses to more than the input limit of 16 MiB (--max-input-mib raises it)") != std::string::npos);
  }
}
