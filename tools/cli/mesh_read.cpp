// Mesh reading through Assimp: the only translation unit that includes Assimp (it compiles slowly).
#include "error.hpp"
#include "file_io.hpp"
#include "mesh.hpp"

#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/fast_atof.h>
#include <assimp/scene.h>

#include <charconv>
#include <cmath>
#include <optional>
#include <cstring>
#include <unordered_map>

namespace mlsdeform::cli {
namespace {

// What fast_atof throws on a malformed number. (Assimp's default, DeadlyImportError, needs a constructor that
// Debian's libassimp does not export.)
struct NotANumber {
  template <class... Args>
  explicit NotANumber(Args&&...) {}
};

struct ObjVertex {
  float x, y, z;
  std::size_t line;
};

// The positions of an OBJ file's `v` lines in file order. Assimp's OBJ importer gives every face corner its own
// vertex, so the file's numbering is lost; we recover it by matching each corner's position against this list.
// The numbers are parsed with Assimp's own fast_atof, exactly as its importer does, so that the match is exact.
std::vector<ObjVertex> scan_obj_vertices(std::string_view text, const std::string& path) {
  std::vector<ObjVertex> out;
  std::size_t line = 0, pos = 0;
  std::string token;
  while (pos < text.size()) {
    ++line;
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view l = text.substr(pos, end - pos);
    pos = end + 1;
    std::size_t i = l.find_first_not_of(" \t");
    if (i == std::string_view::npos || l[i] != 'v' || i + 1 >= l.size() || (l[i + 1] != ' ' && l[i + 1] != '\t')) continue;
    // Tokens after "v", up to a comment.
    float c[7];
    int n = 0;
    std::size_t j = i + 1;
    for (;;) {
      j = l.find_first_not_of(" \t\r", j);
      if (j == std::string_view::npos || l[j] == '#') break;
      std::size_t k = l.find_first_of(" \t\r#", j);
      if (k == std::string_view::npos) k = l.size();
      if (n == 7) {
        ++n;
        break;
      }
      token.assign(l.substr(j, k - j));
      try {
        Assimp::fast_atoreal_move<float, NotANumber>(token.c_str(), c[n++]);
      } catch (const NotANumber&) {
        throw InputError(path, "not a number: '" + token + "'", "line " + std::to_string(line));
      }
      j = k;
    }
    if (n == 3 || n == 6) {
      out.push_back({c[0], c[1], c[2], line});
    } else if (n == 4) {  // homogeneous coordinates, divided as Assimp does
      if (c[3] == 0.0f) throw InputError(path, "vertex with w = 0", "line " + std::to_string(line));
      out.push_back({c[0] / c[3], c[1] / c[3], c[2] / c[3], line});
    } else {
      throw InputError(path, "a vertex needs 3 coordinates (x y z, optionally w, or x y z r g b), found " + std::to_string(n),
                       "line " + std::to_string(line));
    }
  }
  return out;
}

struct BitsHash {
  std::size_t operator()(const std::array<std::uint32_t, 3>& k) const {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (auto v : k) h = (h ^ v) * 0x100000001b3ull;
    return std::size_t(h ^ (h >> 29));
  }
};

std::array<std::uint32_t, 3> bits(float x, float y, float z) {
  std::array<std::uint32_t, 3> b;
  std::memcpy(&b[0], &x, 4);
  std::memcpy(&b[1], &y, 4);
  std::memcpy(&b[2], &z, 4);
  return b;
}

// Some Assimp importers repair a malformed file silently and only log an error (the OFF importer, for one,
// replaces an out-of-range vertex index by the last vertex). We log Assimp's errors while importing and treat the
// first as a parse error rather than deform a corrupted mesh.
class AssimpErrors : public Assimp::LogStream {
 public:
  AssimpErrors() {
    Assimp::DefaultLogger::create("", Assimp::Logger::NORMAL, 0);  // no file, no default streams
    Assimp::DefaultLogger::get()->attachStream(this, Assimp::Logger::Err);
  }
  ~AssimpErrors() override {
    Assimp::DefaultLogger::get()->detachStream(this, Assimp::Logger::Err);  // hands the stream back to us
    Assimp::DefaultLogger::kill();
  }
  AssimpErrors(const AssimpErrors&) = delete;
  AssimpErrors& operator=(const AssimpErrors&) = delete;
  void write(const char* message) override {
    if (first.empty()) first = message;
  }
  std::string first;
};

std::string one_line(std::string why) {
  while (!why.empty() && (why.back() == '\n' || why.back() == '\r' || why.back() == ' ')) why.pop_back();
  for (auto& c : why)
    if (c == '\n' || c == '\r') c = ' ';
  return why;
}

// The structure of a PLY file, checked before Assimp sees it: Assimp's PLY importer loops forever on a header
// without "end_header", reads past the end of a truncated binary body and accepts a truncated ASCII body. We
// check the header, walk a binary body to its promised end, and compare Assimp's counts with the header's.
struct PlyCounts {
  std::uint64_t vertices = 0, faces = 0;
};

PlyCounts check_ply(std::string_view data, const std::string& path) {
  auto fail = [&](const std::string& why, std::size_t line = 0) {
    throw InputError(path, "malformed PLY: " + why, line ? "line " + std::to_string(line) : std::string());
  };
  std::size_t pos = 0, line_no = 0;
  auto next_line = [&]() -> std::string_view {
    const std::size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) fail("the header has no end_header line");
    std::string_view l = data.substr(pos, end - pos);
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    pos = end + 1;
    ++line_no;
    return l;
  };
  auto words = [](std::string_view l) {
    std::vector<std::string> w;
    std::size_t i = 0;
    while ((i = l.find_first_not_of(" \t", i)) != std::string_view::npos) {
      const std::size_t j = std::min(l.find_first_of(" \t", i), l.size());
      w.emplace_back(l.substr(i, j - i));
      i = j;
    }
    return w;
  };
  auto type_size = [&](const std::string& t) -> std::size_t {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32") return 4;
    if (t == "double" || t == "float64") return 8;
    fail("unknown property type '" + t + "'", line_no);
    return 0;
  };
  struct Property {
    std::size_t size = 0, count_size = 0;  // count_size > 0: a list
  };
  struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Property> properties;
  };
  if (next_line() != "ply") fail("the first line is not 'ply'", 1);
  std::string format;
  std::vector<Element> elements;
  for (;;) {
    const auto w = words(next_line());
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "end_header") break;
    if (w[0] == "format" && w.size() >= 2) {
      format = w[1];
    } else if (w[0] == "element" && w.size() == 3) {
      std::uint64_t n = 0;
      const auto r = std::from_chars(w[2].data(), w[2].data() + w[2].size(), n);
      if (r.ec != std::errc() || r.ptr != w[2].data() + w[2].size()) fail("bad element count '" + w[2] + "'", line_no);
      elements.push_back({w[1], n, {}});
    } else if (w[0] == "property" && !elements.empty() && w.size() == 5 && w[1] == "list") {
      elements.back().properties.push_back({type_size(w[3]), type_size(w[2])});
    } else if (w[0] == "property" && !elements.empty() && w.size() == 3) {
      elements.back().properties.push_back({type_size(w[1]), 0});
    } else {
      fail("unexpected header line", line_no);
    }
  }
  if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") fail("unknown format '" + format + "'");
  PlyCounts counts;
  for (const auto& e : elements) {
    if (e.name == "vertex") counts.vertices = e.count;
    if (e.name == "face") counts.faces = e.count;
  }
  if (format == "ascii") {
    // Count the tokens the header promises (a list's first token says how many follow).
    auto token = [&]() -> std::string_view {
      const std::size_t b = data.find_first_not_of(" \t\r\n", pos);
      if (b == std::string_view::npos) return {};
      const std::size_t e = std::min(data.find_first_of(" \t\r\n", b), data.size());
      pos = e;
      return data.substr(b, e - b);
    };
    for (const auto& e : elements)
      for (std::uint64_t i = 0; i < e.count; ++i)
        for (const auto& p : e.properties) {
          const std::string_view t = token();
          if (t.empty()) fail("truncated in " + e.name + " " + std::to_string(i) + " of " + std::to_string(e.count));
          if (!p.count_size) continue;
          std::uint64_t n = 0;
          const auto r = std::from_chars(t.data(), t.data() + t.size(), n);
          if (r.ec != std::errc() || r.ptr != t.data() + t.size())
            fail("bad list length '" + std::string(t) + "' in " + e.name + " " + std::to_string(i));
          for (std::uint64_t k = 0; k < n; ++k)
            if (token().empty()) fail("truncated in " + e.name + " " + std::to_string(i) + " of " + std::to_string(e.count));
        }
    return counts;
  }
  const bool big = format == "binary_big_endian";
  for (const auto& e : elements) {
    for (std::uint64_t i = 0; i < e.count; ++i) {
      for (const auto& p : e.properties) {
        std::uint64_t n = 1;
        if (p.count_size) {
          if (data.size() - pos < p.count_size) fail("truncated in " + e.name + " " + std::to_string(i) + " of " + std::to_string(e.count));
          n = 0;
          for (std::size_t b = 0; b < p.count_size; ++b)  // list counts are unsigned in practice
            n |= std::uint64_t(static_cast<unsigned char>(data[pos + (big ? p.count_size - 1 - b : b)])) << (8 * b);
          pos += p.count_size;
        }
        if ((data.size() - pos) / p.size < n)
          fail("truncated in " + e.name + " " + std::to_string(i) + " of " + std::to_string(e.count));
        pos += std::size_t(n) * p.size;
      }
    }
  }
  return counts;
}

std::string upper(std::string s) {
  for (auto& c : s) c = char(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

float detail::assimp_atof(const char* text) {
  float v = 0;
  try {
    Assimp::fast_atoreal_move<float, NotANumber>(text, v);
  } catch (const NotANumber&) {
    return std::numeric_limits<float>::quiet_NaN();
  }
  return v;
}

std::string readable_formats() { return "obj, off, ply (ASCII or binary), and each gzip-compressed (.obj.gz, .off.gz, .ply.gz)"; }

Mesh read_mesh(const std::string& path) {
  const std::string ext = format_extension(path);
  if (ext != "obj" && ext != "off" && ext != "ply")
    throw InputError(path, "unknown mesh format" + (ext.empty() ? std::string() : " '." + ext + "'") +
                               " (readable: " + readable_formats() + ")");
  std::string bytes = read_file(path);
  if (is_gzip_path(path)) bytes = gunzip(bytes, path);
  if (bytes.empty()) throw InputError(path, "empty file");

  // Checks of our own where Assimp's importers are lax (see check_ply and scan_obj_vertices).
  std::optional<PlyCounts> ply;
  if (ext == "ply") ply = check_ply(bytes, path);
  std::vector<ObjVertex> obj_vertices;
  if (ext == "obj") obj_vertices = scan_obj_vertices(bytes, path);

  // No post-processing: no triangulation, no joining of vertices, no generated normals. The file as it is.
  Assimp::Importer importer;
  const AssimpErrors errors;
  const aiScene* scene = importer.ReadFileFromMemory(bytes.data(), bytes.size(), 0, ext.c_str());
  if (!scene) throw InputError(path, "cannot parse as " + upper(ext) + ": " + one_line(importer.GetErrorString()));
  if (!errors.first.empty()) {
    // Assimp's log lines start with a severity and a time stamp ("Error, T0: OFF: ..."): keep the message.
    std::string why = errors.first;
    if (const auto p = why.find(": "); why.rfind("Error", 0) == 0 && p != std::string::npos) why = why.substr(p + 2);
    throw InputError(path, "cannot parse as " + upper(ext) + ": " + one_line(why));
  }

  Mesh mesh;
  std::size_t dropped = 0;  // points and lines
  if (ext == "obj") {
    const auto& file_vertices = obj_vertices;
    mesh.vertices.resize(Eigen::Index(file_vertices.size()), 3);
    std::unordered_map<std::array<std::uint32_t, 3>, std::uint32_t, BitsHash> index;
    index.reserve(file_vertices.size());
    for (std::size_t i = 0; i < file_vertices.size(); ++i) {
      const auto& v = file_vertices[i];
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
        throw InputError(path, "vertex " + std::to_string(i) + " has a non-finite coordinate", "line " + std::to_string(v.line));
      mesh.vertices.row(Eigen::Index(i)) << v.x, v.y, v.z;
      index.emplace(bits(v.x, v.y, v.z), std::uint32_t(i));  // a repeated position maps to its first vertex
    }
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
      const aiMesh* am = scene->mMeshes[m];
      for (unsigned f = 0; f < am->mNumFaces; ++f) {
        const aiFace& face = am->mFaces[f];
        if (face.mNumIndices < 3) {
          ++dropped;
          continue;
        }
        for (unsigned c = 0; c < face.mNumIndices; ++c) {
          const aiVector3D& p = am->mVertices[face.mIndices[c]];
          const auto it = index.find(bits(p.x, p.y, p.z));
          if (it == index.end())
            throw InputError(path, "could not match a face corner to a vertex line (unsupported OBJ syntax?)");
          mesh.face_indices.push_back(it->second);
        }
        mesh.face_start.push_back(std::uint32_t(mesh.face_indices.size()));
      }
    }
  } else {
    // OFF and PLY: Assimp keeps the file's vertex list and order (every vertex, used or not).
    std::size_t n = 0;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) n += scene->mMeshes[m]->mNumVertices;
    if (n > std::size_t(std::numeric_limits<std::uint32_t>::max())) throw InputError(path, "too many vertices");
    mesh.vertices.resize(Eigen::Index(n), 3);
    std::uint32_t base = 0;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
      const aiMesh* am = scene->mMeshes[m];
      for (unsigned v = 0; v < am->mNumVertices; ++v) {
        const aiVector3D& p = am->mVertices[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
          throw InputError(path, "vertex " + std::to_string(base + v) + " has a non-finite coordinate");
        mesh.vertices.row(Eigen::Index(base + v)) << p.x, p.y, p.z;
      }
      for (unsigned f = 0; f < am->mNumFaces; ++f) {
        const aiFace& face = am->mFaces[f];
        if (face.mNumIndices < 3) {
          ++dropped;
          continue;
        }
        for (unsigned c = 0; c < face.mNumIndices; ++c) {
          if (face.mIndices[c] >= am->mNumVertices)
            throw InputError(path, "face " + std::to_string(mesh.face_count()) + " refers to vertex " +
                                       std::to_string(face.mIndices[c]) + ", but there are only " +
                                       std::to_string(am->mNumVertices));
          mesh.face_indices.push_back(base + face.mIndices[c]);
        }
        mesh.face_start.push_back(std::uint32_t(mesh.face_indices.size()));
      }
      base += am->mNumVertices;
    }
  }
  mesh.dropped_primitives = dropped;
  if (ply && (std::uint64_t(mesh.vertex_count()) != ply->vertices || mesh.face_count() + dropped != ply->faces))
    throw InputError(path, "the header promises " + std::to_string(ply->vertices) + " vertices and " + std::to_string(ply->faces) +
                               " faces, but " + std::to_string(mesh.vertex_count()) + " and " +
                               std::to_string(mesh.face_count() + dropped) + " were read (truncated?)");
  if (mesh.vertex_count() == 0) throw InputError(path, "no vertices");
  return mesh;
}

}  // namespace mlsdeform::cli
