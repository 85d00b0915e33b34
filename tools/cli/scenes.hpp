// mlsdeform CLI: the paper's test scenes, shared by `demo`, `figures` and the tests: a mesh (a bundled model or
// one of Sec. 5's generated primitives, primitives.hpp) with the handle sets of Fig. 1 to 8 and their targets
// frame by frame (scenes.cpp), and a runner that times Deformer::deform per frame (scene_run.cpp).
#pragma once

#include "core/files/mesh.hpp"
#include "tools/cli/primitives.hpp"

#include <mlsdeform/deformer.hpp>

#include <optional>
#include <string>
#include <vector>

namespace mlsdeform::cli {

// The program is a command layer over the files library (core/files/): its names are the program's own.
using namespace mlsdeform::files;

/// A scene: a mesh, handles at rest and their targets frame by frame, and the options to deform it with.
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

/// Fig. 2 on the shared fish (fish.obj, y up, head towards +z): 4 point handles at vertices, the mouth, the
/// tail tip, the top of the dorsal fin and the bottom of the belly; the fin and the belly stay, the head and
/// the tail turn up (25 and 40 degrees): the fish flexes like the paper's dolphin.
Scene fish_scene(const Mesh& fish);
/// Fig. 6: Table 2's plane (1089 vertices), handles only translated: its two side columns of vertices fixed,
/// the middle column moved along itself (z, in the plane) by a quarter of the plane's width.
Scene plane_translate_scene();
/// Fig. 7: a bar (1666 vertices) with 32 point handles (two rings of 8 at each end), its upper end carried
/// sideways and down by more than the bar's length, without rotation; the lower end fixed.
Scene bar_far_scene();
/// Fig. 8: Table 2's plane with its two side columns of vertices fixed and a row of 5 points in between
/// raised by half the plane's width (the paper's "displacing a row of control points"), with the given
/// centroids.
Scene plane_row_scene(Centroids centroids);

struct SceneRun {
  Points<double> result;              ///< the last frame
  std::vector<double> frame_seconds;  ///< Deformer::deform only
  double setup_seconds = 0;           ///< construction and (successive scenes) reset_rest_pose
  double frames_per_second() const;
};

/// Runs every frame of `scene` with precision T and the given backend and thread count (0: all cores). With
/// `scene.options.arap_iterations` > 0 the deformer gets the mesh's faces (fanned into triangles).
template <class T>
SceneRun run_scene(const Scene& scene, std::optional<Isa> isa = std::nullopt, int threads = 0);

}  // namespace mlsdeform::cli
