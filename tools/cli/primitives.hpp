// mlsdeform CLI: generated meshes, Sec. 5's primitives (Table 2's Plane, Bar and Cylinder, with its vertex and
// constraint counts), and the conversions between a mesh and the library's points.
#pragma once

#include "core/files/mesh.hpp"

#include <mlsdeform/types.hpp>

namespace mlsdeform::cli {

// The program is a command layer over the files library (core/files/): its names are the program's own.
using namespace mlsdeform::files;

/// The surface of an axis-aligned box [-w/2, w/2] x [0, h] x [-w/2, w/2] on an nx x ny x nz grid of quads, y up.
/// Vertex count 2 (nx ny + ny nz + nz nx) + 2: 16 x 88 x 16 gives Table 2's 6146-vertex bar.
Mesh make_bar(int nx, int ny, int nz, double width, double height);
/// A flat sheet in the xz plane (y = 0, normals +y) of nx x nz quads, [-sx/2, sx/2] x [-sz/2, sz/2]. 32 x 32
/// gives Table 2's 1089-vertex plane.
Mesh make_plane(int nx, int nz, double sx, double sz);
/// An open tube of `around` x `rings` vertices (quads), radius r, from y = 0 to y = h. 23 x 46 gives Table 2's
/// 1058-vertex cylinder.
Mesh make_tube(int around, int rings, double radius, double height);

/// The mesh with its vertices replaced (rounded to float), its faces kept.
Mesh with_vertices(const Mesh& mesh, const Points<double>& vertices);
/// The mesh's vertices in double (exactly).
Points<double> to_points(const Mesh& mesh);

}  // namespace mlsdeform::cli
