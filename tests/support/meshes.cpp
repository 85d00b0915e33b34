// See meshes.hpp.
#include "tests/support/meshes.hpp"

#include "tests/support/random.hpp"

#if !MLSDEFORM_NO_ZLIB
#include <zlib.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace mlsdeform::testing {

std::string bundled_mesh(const std::string& file) { return std::string(MLSDEFORM_SOURCE_DIR) + "/data/" + file; }

std::string mesh_dir() {
  if (const char* env = std::getenv("MLSDEFORM_MESHES"); env && *env) return env;
  return std::string(MLSDEFORM_SOURCE_DIR) + "/../shared/data/meshes";
}

std::string shared_mesh(const std::string& file) {
  const std::string path = mesh_dir() + "/" + file;
  return std::filesystem::exists(path) ? path : std::string();
}

PointsD read_obj_vertices(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::vector<double> xyz;
  std::string line;
  while (std::getline(in, line)) {
    if (line.size() < 2 || line[0] != 'v' || line[1] != ' ') continue;
    double x, y, z;
    if (std::sscanf(line.c_str() + 2, "%lf %lf %lf", &x, &y, &z) != 3)
      throw std::runtime_error("bad 'v' line in " + path);
    xyz.insert(xyz.end(), {x, y, z});
  }
  PointsD p(static_cast<Eigen::Index>(xyz.size() / 3), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (int c = 0; c < 3; ++c) p(i, c) = xyz[static_cast<std::size_t>(3 * i + c)];
  return p;
}

const TriangleMesh& human() {
  static const TriangleMesh h{read_obj_vertices(bundled_mesh("human_man.obj")),
                              read_obj_triangles(bundled_mesh("human_man.obj"))};
  return h;
}

Triangles read_obj_triangles(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::vector<long long> corners;  // zero-based, checked against the vertex count at the end
  long long vertices = 0;
  std::string line;
  std::vector<long long> face;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.size() < 2 || line[1] != ' ') continue;
    if (line[0] == 'v') ++vertices;
    if (line[0] != 'f') continue;
    face.clear();
    std::istringstream ss(line.substr(2));
    for (std::string corner; ss >> corner;) {
      char* end = nullptr;
      const long long i = std::strtoll(corner.c_str(), &end, 10);
      if (end == corner.c_str() || (*end != '\0' && *end != '/') || i == 0)
        throw std::runtime_error("bad 'f' line in " + path + ": " + line);
      face.push_back(i > 0 ? i - 1 : vertices + i);
    }
    if (face.size() < 3) throw std::runtime_error("face with fewer than three corners in " + path + ": " + line);
    for (std::size_t k = 1; k + 1 < face.size(); ++k) corners.insert(corners.end(), {face[0], face[k], face[k + 1]});
  }
  Triangles t(static_cast<Eigen::Index>(corners.size() / 3), 3);
  for (std::size_t k = 0; k < corners.size(); ++k) {
    if (corners[k] < 0 || corners[k] >= vertices)
      throw std::runtime_error("face index out of range in " + path + " (" + std::to_string(vertices) + " vertices)");
    t(static_cast<Eigen::Index>(k / 3), static_cast<Eigen::Index>(k % 3)) = static_cast<int>(corners[k]);
  }
  return t;
}

PointsD read_ply_vertices(const std::string& path, Triangles* faces) {
#if MLSDEFORM_NO_ZLIB
  // The WebAssembly tests (web/cmake/tests.cmake) have no zlib; none of the tests built there reads a PLY file.
  (void)faces;
  throw std::runtime_error(path + ": gzip-compressed PLY cannot be read without zlib");
#else
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw std::runtime_error("cannot open " + path);
  auto fail = [&](const std::string& why) {
    gzclose(f);
    return std::runtime_error(path + ": " + why);
  };
  // Header: text lines up to "end_header".
  std::string header_line;
  auto getline = [&]() {
    header_line.clear();
    for (int ch; (ch = gzgetc(f)) != -1 && ch != '\n';) header_line.push_back(static_cast<char>(ch));
    return !header_line.empty() || !gzeof(f);
  };
  if (!getline() || header_line != "ply") throw fail("not a PLY file");
  long long vertices = -1, face_count = -1;
  bool in_vertex = false, seen_vertex = false, in_face = false, face_list = false;
  int stride = 0, offset[3] = {-1, -1, -1};
  auto size_of = [](const std::string& t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
    if (t == "double" || t == "float64") return 8;
    return 0;
  };
  while (getline()) {
    std::istringstream ss(header_line);
    std::string word;
    ss >> word;
    if (word == "format") {
      std::string fmt;
      ss >> fmt;
      if (fmt != "binary_little_endian") throw fail("only binary_little_endian PLY is supported");
    } else if (word == "element") {
      std::string name;
      long long count;
      ss >> name >> count;
      in_vertex = name == "vertex";
      in_face = name == "face";
      if (faces && seen_vertex && !in_face && face_count < 0) throw fail("an element between vertex and face");
      if (in_face) face_count = count;
      if (in_vertex) {
        if (seen_vertex) throw fail("two vertex elements");
        vertices = count, seen_vertex = true;
      } else if (!seen_vertex) {
        throw fail("the vertex element must come first");
      }
    } else if (word == "property" && in_face && faces) {
      std::string list, count_type, index_type, name;
      ss >> list >> count_type >> index_type >> name;
      if (face_list || list != "list" || count_type != "uchar" || (index_type != "int" && index_type != "uint"))
        throw fail("faces must be one property 'list uchar int'");
      face_list = true;
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      ss >> type >> name;
      if (type == "list") throw fail("list property in the vertex element");
      const int sz = size_of(type);
      if (!sz) throw fail("unknown property type " + type);
      const bool is_float = type == "float" || type == "float32";
      for (int c = 0; c < 3; ++c)
        if (name == std::string(1, "xyz"[c])) {
          if (!is_float) throw fail("x, y, z must be float");
          offset[c] = stride;
        }
      stride += sz;
    } else if (word == "end_header") {
      break;
    }
  }
  if (vertices < 0 || offset[0] < 0 || offset[1] < 0 || offset[2] < 0) throw fail("no vertex x, y, z");
  std::vector<unsigned char> buf(static_cast<std::size_t>(vertices) * static_cast<std::size_t>(stride));
  std::size_t got = 0;
  while (got < buf.size()) {
    const unsigned chunk = static_cast<unsigned>(std::min<std::size_t>(buf.size() - got, 1u << 30));
    const int r = gzread(f, buf.data() + got, chunk);
    if (r <= 0) throw fail("truncated vertex data");
    got += static_cast<std::size_t>(r);
  }
  if (faces) {
    // Each face: a uchar corner count, then that many 32-bit little-endian indices; polygons are fanned.
    if (face_count < 0 || !face_list) throw fail("no face element");
    std::vector<Eigen::Vector3i> tri;
    std::vector<std::int32_t> corner;
    for (long long k = 0; k < face_count; ++k) {
      const int count = gzgetc(f);
      if (count < 3) throw fail(count < 0 ? "truncated face data" : "a face with fewer than 3 corners");
      corner.resize(std::size_t(count));
      const int bytes = count * int(sizeof(std::int32_t));
      if (gzread(f, corner.data(), unsigned(bytes)) != bytes) throw fail("truncated face data");
      for (const std::int32_t c : corner)
        if (c < 0 || c >= vertices) throw fail("face " + std::to_string(k) + " has an index out of range");
      for (int c = 2; c < count; ++c) tri.emplace_back(corner[0], corner[std::size_t(c - 1)], corner[std::size_t(c)]);
    }
    faces->resize(Eigen::Index(tri.size()), 3);
    for (std::size_t k = 0; k < tri.size(); ++k) faces->row(Eigen::Index(k)) = tri[k].transpose();
  }
  gzclose(f);
  PointsD p(vertices, 3);
  for (long long i = 0; i < vertices; ++i)
    for (int c = 0; c < 3; ++c) {
      float v;
      std::memcpy(&v,
                  buf.data() + static_cast<std::size_t>(i) * static_cast<std::size_t>(stride) +
                      static_cast<std::size_t>(offset[c]),
                  sizeof v);
      p(i, c) = v;
    }
  return p;
#endif
}

PointsD random_subset(const PointsD& p, Eigen::Index count, std::uint64_t seed) {
  if (count >= p.rows()) return p;
  std::vector<Eigen::Index> idx(static_cast<std::size_t>(p.rows()));
  std::iota(idx.begin(), idx.end(), Eigen::Index(0));
  Rng rng(seed);
  for (Eigen::Index i = 0; i < count; ++i) {
    const auto j = i + static_cast<Eigen::Index>(rng.next() % static_cast<std::uint64_t>(p.rows() - i));
    std::swap(idx[static_cast<std::size_t>(i)], idx[static_cast<std::size_t>(j)]);
  }
  std::sort(idx.begin(), idx.begin() + count);
  PointsD out(count, 3);
  for (Eigen::Index i = 0; i < count; ++i) out.row(i) = p.row(idx[static_cast<std::size_t>(i)]);
  return out;
}

PointsD grid(int n) {
  PointsD p(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) p.row(i * n + j) << j, i, 0.0;
  return p;
}

PointsD cylinder(int around, int rings) {
  PointsD p(around * rings, 3);
  const double h = 2 * std::numbers::pi / around;
  for (int r = 0; r < rings; ++r)
    for (int a = 0; a < around; ++a) {
      const double t = 2 * std::numbers::pi * a / around;
      p.row(r * around + a) << std::cos(t), std::sin(t), r * h;
    }
  return p;
}

PointsD box_surface(int a, int b, int c) {
  std::vector<Eigen::Vector3d> v;
  for (int i = 0; i <= a; ++i)
    for (int j = 0; j <= b; ++j)
      for (int k = 0; k <= c; ++k)
        if (i == 0 || i == a || j == 0 || j == b || k == 0 || k == c) v.emplace_back(i, j, k);
  PointsD p(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) p.row(static_cast<Eigen::Index>(i)) = v[i].transpose();
  return p;
}

Triangles box_surface_triangles(int a, int b, int c) {
  // The vertex numbering of box_surface: the same loops, counting the surface vertices.
  const int dims[3] = {a, b, c};
  std::vector<int> id(static_cast<std::size_t>((a + 1) * (b + 1) * (c + 1)), -1);
  auto at = [&](const int(&g)[3]) -> int& {
    return id[static_cast<std::size_t>((g[0] * (b + 1) + g[1]) * (c + 1) + g[2])];
  };
  int count = 0;
  for (int i = 0; i <= a; ++i)
    for (int j = 0; j <= b; ++j)
      for (int k = 0; k <= c; ++k)
        if (i == 0 || i == a || j == 0 || j == b || k == 0 || k == c) at({i, j, k}) = count++;
  std::vector<int> tri;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // (axis, u, v) is a right-handed permutation of (x, y, z)
    for (int side : {0, 1}) {
      // (u, v) counter-clockwise seen from +axis: u x v = +axis. The side at 0 faces -axis, so it is reversed.
      for (int s = 0; s < dims[u]; ++s)
        for (int t = 0; t < dims[v]; ++t) {
          int g00[3], g10[3], g11[3], g01[3];
          for (int* g : {g00, g10, g11, g01}) g[axis] = side * dims[axis];
          g00[u] = g01[u] = s, g10[u] = g11[u] = s + 1;
          g00[v] = g10[v] = t, g01[v] = g11[v] = t + 1;
          const int q[4] = {at(g00), at(g10), at(g11), at(g01)};
          if (side == 1)
            tri.insert(tri.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
          else
            tri.insert(tri.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
        }
    }
  }
  Triangles t(static_cast<Eigen::Index>(tri.size() / 3), 3);
  for (std::size_t k = 0; k < tri.size(); ++k)
    t(static_cast<Eigen::Index>(k / 3), static_cast<Eigen::Index>(k % 3)) = tri[k];
  return t;
}

PointsD random_box(Eigen::Index n, std::uint64_t seed) {
  Rng rng(seed);
  PointsD p(n, 3);
  for (Eigen::Index i = 0; i < n; ++i)
    p.row(i) << 4 * rng.uniform<double>(), rng.uniform<double>(), rng.uniform<double>();
  return p;
}

}  // namespace mlsdeform::testing
