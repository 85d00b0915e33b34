// Malformed mesh files (truncated, out-of-range, inconsistent headers), each with the problem its error must name.
// Shared by the reader's unit test (test_cli_mesh_io.cpp) and the program's end-to-end test
// (test_cli_bad_input.cpp), so that every case is refused both by read_mesh and through `mlsdeform deform`.
#pragma once

#include "core/files/file_io.hpp"
#include "core/files/mesh.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cli_test {

struct MalformedMesh {
  std::string name;      ///< file name; its extension selects the reader
  std::string bytes;     ///< the file's contents
  std::string expected;  ///< a part of the error message (after "FILE: ")
};

/// The unit cube, 8 vertices and 6 quads, as the tests' meshes are written.
inline mlsdeform::files::Mesh cube_mesh() {
  mlsdeform::files::Mesh cube;
  cube.vertices.resize(8, 3);
  cube.vertices << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  for (auto f :
       {std::array<std::uint32_t, 4>{0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}, {0, 3, 2, 1}, {4, 5, 6, 7}})
    cube.add_face({f[0], f[1], f[2], f[3]});
  return cube;
}

inline std::vector<MalformedMesh> malformed_meshes() {
  using mlsdeform::files::encode_mesh;
  using mlsdeform::files::gzip;
  const std::string cube_v = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
  const std::string off_head = "OFF\n8 6 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n";
  const std::string off_faces = "4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n4 0 3 2 1\n4 4 5 6 7\n";
  const std::string ply_header =
      "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 6\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string ply_vertices = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n";
  const std::string ply_head = ply_header + ply_vertices;
  const std::string ply_faces = off_faces;
  std::vector<MalformedMesh> cases = {
      // Finding 1: malformed faces that were accepted and rewritten.
      {"neg.off", off_head + "4 0 -1 5 4\n" + off_faces,
       "line 11: face 0 refers to vertex -1, but there are only 8 vertices"},
      {"short.off", off_head + off_faces + "4 3 0 4\n", "line 16: face 5 promises 4 vertices but has 3 numbers"},
      {"x.off", off_head + "4 0 1 x 4\n" + off_faces, "line 11: face 0: not an index: 'x'"},
      {"trailing.off", off_head + off_faces + "4 0 1 5 4\n4 0 1 2 3\n",
       "line 17: malformed OFF: data after the last face"},
      {"eq.ply", ply_head + "4 = 1 5 4\n" + ply_faces, "line 18: not a number: '=' in face 0"},
      {"trailing.ply", ply_head + "4 0 1 5 4\n" + ply_faces + "3 0 1 2\n", "data after the last element (line 24)"},
      {"nine.ply",
       "ply\nformat ascii 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 6\nproperty list uchar int vertex_indices\nend_header\n" +
           ply_vertices + "4 0 1 5 4\n" + ply_faces,
       "line 18: too many values for vertex 8"},
      // Finding 2: lenient numbers.
      {"dots.obj", cube_v + "v 1 1.5.5 1\nf 1 2 3\n", "line 9: not a number: '1.5.5'"},
      {"hex.obj", cube_v + "v 1 0x1p3 1\nf 1 2 3\n", "line 9: not a number: '0x1p3'"},
      // Finding 3: counts that the body cannot hold, refused before allocating.
      {"count.off", "OFF\n100000000 1 0\n0 0 0\n", "the header promises 100000000 vertices"},
      {"faces.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 100000000\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
       "the header promises 100000000 face elements"},
      // More of the same kinds.
      {"face.obj", cube_v + "f 1 2\n", "line 9: a face needs at least 3 vertices, found 2"},
      {"idx.obj", cube_v + "f 1 2 x\n", "line 9: not a vertex index: 'x'"},
      {"zero.obj", cube_v + "f 0 1 2\n", "line 9: not a vertex index: '0'"},
      {"range.obj", cube_v + "f 1 2 9\n", "line 9: vertex index 9 is out of range (8 vertices)"},
      {"stmt.obj", cube_v + "curv 0 1 2\n", "line 9: unsupported OBJ statement 'curv'"},
      // Issue 45: a fourth part of a corner was dropped when written back, a texture index out of range kept, and a
      // two-corner face of a minimal OFF refused by the byte count before its own message.
      {"corner4.obj", cube_v + "vt 0 0\nvn 0 0 1\nf 1/1/1/7 2/1/1 3/1/1\n",
       "line 11: a face corner is v, v/vt, v//vn or v/vt/vn, found '1/1/1/7'"},
      {"vt.obj", cube_v + "vt 0 0\nf 1/9 2/1 3/1\n", "line 10: texture coordinate index 9 is out of range (1 vt)"},
      {"vt0.obj", cube_v + "vt 0 0\nf 1/0 2/1 3/1\n", "line 10: not a texture coordinate index: '1/0'"},
      {"vtneg.obj", cube_v + "vt 0 0\nf 1/-2 2/1 3/1\n",
       "line 10: texture coordinate index -2 refers before the first vt"},
      {"two.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
       "line 6: face 0: expected a vertex count of at least 3, found '2'"},
      // Bytes of a binary file read as text: shown escaped, and the message stays one line.
      {"binary.obj", cube_v + "\x1c\x01\xff 1 2\n", "line 9: unsupported OBJ statement '\\x1c\\x01\\xff'"},
      {"noprops.ply", "ply\nformat binary_little_endian 1.0\nelement junk 4000000000\nend_header\n",
       "malformed PLY: element 'junk' has no properties"},
      {"uchar.ply", ply_head + "256 0 1 5 4\n" + ply_faces, "line 18: '256' in face 0 is out of the range of its type"},
  };
  // A binary PLY whose header promises 7 vertices for a body of 8 and 6 faces: the 8th vertex is read as a face.
  std::string bin = encode_mesh(cube_mesh(), "c.ply");
  bin[bin.find("element vertex 8") + 15] = '7';
  cases.push_back({"seven.ply", bin, "face 0 has 0 vertices (at least 3)"});
  // The same body after the faces: trailing data.
  cases.push_back({"trailing_bin.ply", encode_mesh(cube_mesh(), "c.ply") + std::string(5, '\0'),
                   "malformed PLY: 5 bytes of data after the last element"});
  // Binary, declaring 10^8 faces in a file that holds 6: the count is checked against the bytes that follow and
  // refused before anything is allocated for it (a small .ply.gz must not cost gigabytes and many seconds).
  std::string many = encode_mesh(cube_mesh(), "c.ply");
  many.replace(many.find("element face 6"), 14, "element face 100000000");
  cases.push_back({"many.ply.gz", gzip(many), "the header promises 100000000 face elements"});
  // gzip: not gzip at all, cut short, and more than the input limit once decompressed (a "gzip bomb").
  cases.push_back({"plain.ply.gz", encode_mesh(cube_mesh(), "c.ply"), "corrupt gzip data (incorrect header check)"});
  const std::string gz = encode_mesh(cube_mesh(), "c.ply.gz");
  cases.push_back({"short.ply.gz", gz.substr(0, gz.size() / 2), "truncated gzip data"});
  return cases;
}

}  // namespace cli_test
