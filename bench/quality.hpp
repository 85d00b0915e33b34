// bench_quality's shared parts (bench_quality.cpp has the program and its usage): the settings, the scenes
// and their rows, the timing and the table printing, and the entry of each section that has its own file
// (quality_centroids.cpp, quality_large.cpp, quality_arap.cpp).
#pragma once

#include "tests/support/meshes.hpp"
#include "tests/support/quality.hpp"

#include <mlsdeform/arap.hpp>
#include <mlsdeform/deformer.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace bench::quality {

using mlsdeform::Handles;
using mlsdeform::Points;
using mlsdeform::Triangles;
using mlsdeform::testing::PointsD;
using mlsdeform::testing::ShapeQuality;

struct Settings {
  int threads = 0;
  double min_time = 0.5;
  bool use_double = false;
  bool centroids = false;
  bool arap = false;  // --arap: the ARAP section only
  std::string json;
};

// A triangle mesh with point handles at some of its vertices, each moved to its target.
struct QualityScene {
  std::string name, description;
  PointsD rest;
  Triangles triangles;
  std::vector<Eigen::Index> handles;  // vertex indices
  PointsD targets;                    // targets.row(k) for handles[k]
};

struct Row {
  std::string tool;
  double ms = 0;
  ShapeQuality quality;
};

PointsD rows_of(const PointsD& p, const std::vector<Eigen::Index>& idx);

QualityScene plane_row_scene();
QualityScene human_scene();
QualityScene bar_scene();
std::optional<QualityScene> fish_scene();

// The median of the times of `frame` (ms): one untimed warm-up call, then at least 3 calls and at least
// `min_time` seconds.
double ms_per_frame(const std::function<void()>& frame, double min_time);
// Throws unless every handle vertex ends at its target.
void check_handles(const QualityScene& s, const std::string& tool, const PointsD& x);
void print_table(const QualityScene& s, const std::vector<Row>& rows);
std::string json_row(const QualityScene& s, const Row& r);

// --centroids: the table of one scene; returns its JSON rows.
std::vector<std::string> centroid_section(const QualityScene& s, const Settings& set);
void print_conditioning_table();
// spot_loop3: prints the table; returns its JSON rows, one per factorisation the build has (none where skipped).
template <class T>
std::vector<std::string> print_large_arap(const Settings& set);
// The ARAP section (quality_arap.cpp) over the scenes human, bar and fish, and the subdivided human.
template <class T>
std::vector<std::string> arap_section(const std::vector<QualityScene>& scenes, const Settings& set);
// Loop subdivision in place (quality_subdivide.cpp).
void loop_subdivide(PointsD& v, Triangles& f);

}  // namespace bench::quality
