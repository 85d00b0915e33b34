// Vertex sets of the tests and benchmarks: where the meshes are (the bundled data/ and the shared
// ../shared/data/meshes, see LICENSES.txt there for sources and attribution), two small readers (OBJ 'v'
// lines; binary little-endian PLY, optionally gzip-compressed), and generated shapes (the paper's Table 2
// Plane, Bar and Cylinder; random boxes). Only positions matter to MLS deformation (it never looks at the
// faces), so the vertex readers skip faces; the triangle reader and the box-surface triangles serve what does
// need them (surface ARAP, the quality benchmark's one-rings). Everything in double.
#pragma once

#include <mlsdeform/arap.hpp>  // Triangles
#include <mlsdeform/types.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <string>

namespace mlsdeform::testing {

using PointsD = Points<double>;

/// The bundled mesh data/<file> of the source tree.
std::string bundled_mesh(const std::string& file);

/// The shared mesh folder: $MLSDEFORM_MESHES, else ../shared/data/meshes beside the source tree (it may be
/// absent, as in a checkout of the repository alone).
std::string mesh_dir();

/// mesh_dir()/<file> when that file exists, else "" (a test then skips, saying so).
std::string shared_mesh(const std::string& file);

/// The 'v x y z' lines of a Wavefront OBJ file. Throws std::runtime_error when the file cannot be read or a
/// 'v' line has fewer than three numbers.
PointsD read_obj_vertices(const std::string& path);

/// The 'f' lines of a Wavefront OBJ file as triangles, each polygon a0 a1 ... ak fanned from its first
/// corner into (a0, a_i, a_i+1). Corners may be written v, v/vt, v//vn or v/vt/vn; negative indices count back
/// from the last 'v' line read so far (the OBJ rule). Throws std::runtime_error when the file cannot be read, or
/// a face has fewer than three corners or an index that names no vertex of the file.
Triangles read_obj_triangles(const std::string& path);

/// A mesh's vertices and triangles, as read_obj_vertices and read_obj_triangles read them.
struct TriangleMesh {
  PointsD v;
  Triangles f;
};

/// The bundled human, data/human_man.obj (6,890 vertices), read on first use and kept: the tests that deform
/// it share one copy.
const TriangleMesh& human();

/// The vertices of a binary little-endian PLY file, optionally gzip-compressed (zlib reads both). Supports
/// a vertex element whose properties are scalars (float, double, uchar, int ...) with x, y, z among them
/// (float). With `faces`, also the face element that must follow it: one property 'list uchar int' (or
/// uint), polygons fanned into triangles. Throws std::runtime_error naming the file otherwise.
PointsD read_ply_vertices(const std::string& path, Triangles* faces = nullptr);

/// `count` distinct rows of `p` chosen uniformly at random (Rng(seed); partial Fisher-Yates), in their
/// original order; all of `p` when count >= its rows. Brings a mesh to a given vertex count: MLS cost depends
/// on the number of vertices, not on the connectivity.
PointsD random_subset(const PointsD& p, Eigen::Index count, std::uint64_t seed);

/// The paper's Plane: an n x n grid in the xy plane, unit spacing (33 x 33 = 1,089 vertices).
PointsD grid(int n);

/// An open cylinder along z: `rings` rings of `around` vertices, radius 1, ring spacing 2 pi / around
/// (square quads). The paper's Cylinder has 1,058 = 46 x 23 vertices.
PointsD cylinder(int around, int rings);

/// The surface vertices of an a x b x c box of unit cells (a parallelepiped, the paper's Fig. 3 Bar):
/// (a+1)(b+1)(c+1) - (a-1)(b-1)(c-1) vertices; 16 x 16 x 88 gives the paper's 6,146.
PointsD box_surface(int a, int b, int c);

/// Triangles over box_surface(a, b, c)'s vertices (same indices): every unit square of the six sides cut along
/// its diagonal from the corner of smallest coordinates, so 4 (ab + bc + ca) triangles, all counter-clockwise
/// seen from outside (normals point out of the box).
Triangles box_surface_triangles(int a, int b, int c);

/// n points uniform in the 4 x 1 x 1 box [0, 4) x [0, 1) x [0, 1) (Rng(seed), double variates).
PointsD random_box(Eigen::Index n, std::uint64_t seed);

}  // namespace mlsdeform::testing
