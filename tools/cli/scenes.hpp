// mlsdeform CLI: the paper's test scenes, shared by `demo` and `figures`: the generated primitives of Sec. 5
// (Table 2's Bar and Cylinder, with its vertex and constraint counts), the handle sets of Fig. 1, 3, 4 and 5,
// and a runner that times Deformer::deform per frame.
#pragma once

#include "mesh.hpp"

#include <mlsdeform/deformer.hpp>

#include <string>
#include <vector>

namespace mlsdeform::cli {

/// The surface of an axis-aligned box [-w/2, w/2] x [0, h] x [-w/2, w/2] on an nx x ny x nz grid of quads, y up.
/// Vertex count 2 (nx ny + ny nz + nz nx) + 2: 16 x 88 x 16 gives Table 2's 6146-vertex bar.
Mesh make_bar(int nx, int ny, int nz, double width, double height);
/// An open tube of `around` x `rings` vertices (quads), radius r, from y = 0 to y = h. 23 x 46 gives Table 2's
/// 1058-vertex cylinder.
Mesh make_tube(int around, int rings, double radius, double height);

struct Scene {
  std::string name;         ///< file-name stem
  std::string description;  ///< one line for the demo's table
  Mesh mesh;
  Handles<double> rest;
  std::vector<Handles<double>> frames;  ///< targets, one per frame
  Options options;
  /// Fig. 3's "several small-angle torsions in succession": frame f deforms frame f-1's result, whose handles
  /// are frame f-1's targets (Deformer::reset_rest_pose between frames).
  bool successive = false;
};

/// Fig. 1 on the bundled human (data/human_man.obj, y up, facing +z): toes and heels fixed, the head rotated
/// forward about the waist by up to `degrees` and the hands brought down to the knees over `frames` frames, the
/// paper's "bend at the waist" (Sec. 7).
Scene human_bend_scene(const Mesh& human, int frames, double degrees = 60, Transform transform = Transform::rigid);
/// The ARAP figure on the bundled human: 8 point handles at vertices (data/human_bend.json's last frame, its
/// left-foot segment as two points): navel, toes and heels fixed, the head moved forward and down, the hands
/// brought from the T pose down in front of the knees. One frame; set `options.arap_iterations` for MLS + ARAP.
Scene human_arap_scene(const Mesh& human);
/// Fig. 3: Table 2's bar (6146 vertices, 256 handles: the two outer rings at each end), its top end twisted
/// about the bar's axis by `steps` successive torsions of `degrees / steps` each.
Scene bar_twist_scene(int steps, double degrees = 180);
/// Fig. 5: Table 2's cylinder (1058 vertices, 322 handles: the 7 lowest and 7 highest rings), its top group
/// rotated by up to `degrees` about a horizontal axis through the top's centre, weights |p - v|^-u.
Scene cylinder_scene(double u, int frames, double degrees = 120);
/// Fig. 4: a bar bent by 90 degrees at its upper end, controlled by (0) a few points, (1) more points, or
/// (2) line segments (Sec. 6.2).
Scene bar_bend_scene(int variant, int frames);

/// The weighted centroids q* = sum_i w_i q_i / sum_i w_i of eq. (2) (Sec. 6.2's midpoint rule for segments,
/// w = d^-u with d the distance to the rest handle), per vertex: what Fig. 5's lower row draws.
Points<double> weighted_centroids(const Points<double>& vertices, const Handles<double>& rest,
                                  const Handles<double>& moved, double u);

struct SceneRun {
  Points<double> result;              ///< the last frame
  std::vector<double> frame_seconds;  ///< Deformer::deform only
  double setup_seconds = 0;           ///< construction and (successive scenes) reset_rest_pose
  double frames_per_second() const;
};

/// Runs every frame of `scene` with precision T and the given backend and thread count (0: all cores). With
/// `scene.options.arap_iterations` > 0 the deformer gets the mesh's faces (fanned into triangles).
template <class T>
SceneRun run_scene(const Scene& scene, Backend backend, int threads = 0);

Mesh with_vertices(const Mesh& mesh, const Points<double>& vertices);
Points<double> to_points(const Mesh& mesh);

}  // namespace mlsdeform::cli
