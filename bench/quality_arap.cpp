// bench_quality's ARAP section (bench_quality.cpp describes its tables): convergence against iterations and
// time, plain and Anderson-accelerated, from MLS; warm starts on animations; other poses of the human; the
// 10^5-vertex human.
//
// The reference is the converged ARAP of the same energy (ArapRefiner in double, Anderson, from MLS, in
// rounds of 100 iterations until a round changes the energy by less than 1e-6 relative, at most 3,000; the
// line above each table gives its energy E*, the iterations and the last round's change): energy / E* is 1
// there. CGAL's converged rows, where CGAL is built, are in the scene tables
// above (the same energy: quality_cgal.hpp).
#include "bench/quality.hpp"

#include <Eigen/Geometry>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace bench::quality {

namespace {

using mlsdeform::ArapAcceleration;
using mlsdeform::testing::quantile;
using Clock = std::chrono::steady_clock;

const char* name(ArapAcceleration a) { return a == ArapAcceleration::anderson ? "Anderson" : "plain"; }

struct Reference {
  PointsD x;
  double energy = 0, change = 0;  // E*, and the last round's relative change
  int iterations = 0;
};

// The converged result for `targets` (double, Anderson, from MLS): see the file comment.
Reference converged(const QualityScene& s, const PointsD& targets) {
  Handles<double> rest, moved;
  rest.points = rows_of(s.rest, s.handles);
  moved.points = targets;
  PointsD mls;
  mlsdeform::Deformer<double>(s.rest, rest).deform(moved, mls);
  mlsdeform::ArapOptions o;
  o.acceleration = ArapAcceleration::anderson;
  mlsdeform::ArapRefiner<double> arap(s.rest, s.triangles, s.handles, o);
  Reference r;
  r.x = mls;
  r.energy = arap.energy(r.x);
  do {
    arap.refine(r.x, targets, 100, r.x);
    r.iterations += 100;
    const double E = arap.energy(r.x);
    r.change = std::abs(r.energy - E) / E;
    r.energy = E;
  } while (r.change >= 1e-6 && r.iterations < 3000);
  return r;
}

void print_reference(const QualityScene& s, const Reference& r) {
  const ShapeQuality q = mlsdeform::testing::shape_quality(s.rest, r.x, s.triangles);
  std::printf(
      "Converged (%d iterations, double): E* = %.6g (change over the last 100: %.1e), rigidity median / "
      "p95 %.4f / %.4f, edge ratio p1 / p99 %.3f / %.3f.\n\n",
      r.iterations, r.energy, r.change, quantile(q.rigidity, 0.5), quantile(q.rigidity, 0.95),
      quantile(q.edge_ratio, 0.01), quantile(q.edge_ratio, 0.99));
}

// `converged_p95` > 0: the converged result's rigidity p95 too (the warm and pose tables judge against it).
std::string json_arap(const QualityScene& s, const std::string& table, const std::string& label, int iterations,
                      double ms, double energy_ratio, const ShapeQuality& q, double converged_p95 = 0) {
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "{\"scene\": \"%s\", \"table\": \"%s\", \"tool\": \"%s\", \"iterations\": %d, \"ms_per_frame\": "
                "%.6g, \"energy_ratio\": %.6g, \"rigidity_median\": %.6g, \"rigidity_p95\": %.6g, "
                "\"edge_ratio_p1\": %.6g, \"edge_ratio_p99\": %.6g",
                s.name.c_str(), table.c_str(), label.c_str(), iterations, ms, energy_ratio, quantile(q.rigidity, 0.5),
                quantile(q.rigidity, 0.95), quantile(q.edge_ratio, 0.01), quantile(q.edge_ratio, 0.99));
  std::string out = buf;
  if (converged_p95 > 0) {
    std::snprintf(buf, sizeof buf, ", \"converged_rigidity_p95\": %.6g", converged_p95);
    out += buf;
  }
  return out + "}";
}

// `p95_ratio` >= 0: one more column, rigidity p95 against the converged result's.
void print_row(const std::string& label, int iterations, double ms, double energy_ratio, const ShapeQuality& q,
               double p95_ratio = -1) {
  std::printf("| %s | %d | %.3g | %.4f | %.4f / %.4f | %.3f / %.3f |", label.c_str(), iterations, ms, energy_ratio,
              quantile(q.rigidity, 0.5), quantile(q.rigidity, 0.95), quantile(q.edge_ratio, 0.01),
              quantile(q.edge_ratio, 0.99));
  if (p95_ratio >= 0) std::printf(" %.3f |", p95_ratio);
  std::printf("\n");
  std::fflush(stdout);
}

const char* kHeader =
    "| solver | iterations | ms per frame | energy / E* | rigidity median / p95 | edge ratio p1 / p99 |\n"
    "|---|---:|---:|---:|---:|---:|\n";

// MLS + k ARAP iterations from MLS (a fresh Deformer, each frame timed as in the scene tables): the result, and
// its ms per frame in `ms`.
template <class T>
PointsD from_mls(const QualityScene& s, const Settings& set, const Handles<T>& rest_handles, const Handles<T>& moved,
                 ArapAcceleration a, int k, double& ms) {
  mlsdeform::Options o;
  o.threads = set.threads;
  o.arap_iterations = k;
  o.arap_acceleration = a;
  const mlsdeform::Deformer<T> d(s.rest.cast<T>(), s.triangles, rest_handles, o);
  Points<T> out;
  ms = ms_per_frame([&] { d.deform(moved, out); }, std::min(set.min_time, 0.2));
  return out.template cast<double>();
}

// One Deformer per row: MLS + k ARAP iterations from MLS, each frame timed as in the scene tables.
template <class T>
void convergence_table(const QualityScene& s, const Settings& set, std::vector<std::string>& json) {
  std::printf(
      "\n### ARAP convergence: %s\n\nMLS + k ARAP iterations from MLS (Deformer, %s), plain and "
      "Anderson-accelerated (window 5).\n",
      s.name.c_str(), set.use_double ? "double" : "float");
  const Reference ref = converged(s, s.targets);
  print_reference(s, ref);
  std::printf("%s", kHeader);
  mlsdeform::ArapRefiner<double> judge(s.rest, s.triangles, s.handles);
  Handles<T> rest_handles, moved;
  rest_handles.points = rows_of(s.rest, s.handles).cast<T>();
  moved.points = s.targets.cast<T>();
  for (const ArapAcceleration a : {ArapAcceleration::none, ArapAcceleration::anderson})
    for (const int k : {1, 2, 5, 10, 20, 40, 80}) {
      double ms = 0;
      const PointsD x = from_mls(s, set, rest_handles, moved, a, k, ms);
      check_handles(s, name(a), x);
      const ShapeQuality q = mlsdeform::testing::shape_quality(s.rest, x, s.triangles);
      const double ratio = judge.energy(x) / ref.energy;
      print_row(name(a), k, ms, ratio, q);
      json.push_back(json_arap(s, "convergence", name(a), k, ms, ratio, q));
    }
}

// An animation: the scene's handles with per-frame targets.
struct Animation {
  QualityScene scene;
  std::vector<PointsD> frames;
  std::string description;
};

// data/human_bend.json's 24 frames (head and hands move; navel and feet stay), on the human scene's handles
// (which list the moved ones last, in the file's order).
Animation human_animation(const QualityScene& human) {
  std::ifstream in(std::string(MLSDEFORM_SOURCE_DIR) + "/data/human_bend.json");
  if (!in) throw std::runtime_error("data/human_bend.json: cannot read");
  Animation a{human, {}, "data/human_bend.json, 24 frames"};
  std::string line;
  while (std::getline(in, line)) {
    if (line.find("{\"points\": [null") == std::string::npos) continue;
    for (char& c : line)
      if (c == '[' || c == ']' || c == ',' || c == '{' || c == '}') c = ' ';
    std::istringstream words(line.substr(line.find("null")));
    PointsD t = human.targets;
    std::string w;
    int moved = 0;
    while (words >> w) {
      if (w == "null") continue;  // a handle that stays where it is
      const double x = std::stod(w);
      double y, z;
      words >> y >> z;
      t.row(t.rows() - 3 + moved++) << x, y, z;
    }
    if (moved != 3) throw std::runtime_error("data/human_bend.json: a frame without three moved points");
    a.frames.push_back(t);
  }
  if (a.frames.size() != 24) throw std::runtime_error("data/human_bend.json: expected 24 frames");
  return a;
}

// The bar twisted from 0 to 135 degrees in 24 equal steps.
Animation bar_animation(const QualityScene& bar) {
  Animation a{bar, {}, "the bar twisted from 0 to 135 degrees in 24 frames"};
  const PointsD rest = rows_of(bar.rest, bar.handles);
  for (int f = 1; f <= 24; ++f) {
    PointsD t = rest;
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(135.0 * f / 24 * std::numbers::pi / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d axis(8, 8, 0);
    for (Eigen::Index k = 0; k < t.rows(); ++k)
      if (rest(k, 2) > 0) t.row(k) = (R * (rest.row(k).transpose() - axis) + axis).transpose();
    a.frames.push_back(t);
  }
  return a;
}

// Each row runs the whole animation once on a fresh session (each frame timed once: a warm-started frame
// depends on the one before it); quality and energy at the last frame.
template <class T>
void warm_table(const Animation& an, const Settings& set, const std::vector<int>& iterations,
                std::vector<std::string>& json) {
  const QualityScene& s = an.scene;
  std::printf(
      "\n### ARAP warm starts: %s (%lld vertices)\n\n%s; ms per frame: the mean over the frames; the "
      "other columns at the last frame, against its converged result. Warm: Options::arap_warm_start (limit "
      "0.05 of the diagonal).\n",
      s.name.c_str(), static_cast<long long>(s.rest.rows()), an.description.c_str());
  const Reference ref = converged(s, an.frames.back());
  print_reference(s, ref);
  const ShapeQuality qref = mlsdeform::testing::shape_quality(s.rest, ref.x, s.triangles);
  std::printf(
      "| solver | iterations | ms per frame | energy / E* | rigidity median / p95 | edge ratio p1 / p99 | "
      "p95 / converged p95 |\n|---|---:|---:|---:|---:|---:|---:|\n");
  mlsdeform::ArapRefiner<double> judge(s.rest, s.triangles, s.handles);
  const Points<T> rest = s.rest.cast<T>();
  Handles<T> rest_handles, moved;
  rest_handles.points = rows_of(s.rest, s.handles).cast<T>();
  for (const bool warm : {false, true})
    for (const ArapAcceleration a : {ArapAcceleration::none, ArapAcceleration::anderson})
      for (const int k : iterations) {
        mlsdeform::Options o;
        o.threads = set.threads;
        o.arap_iterations = k;
        o.arap_acceleration = a;
        o.arap_warm_start = warm;
        const mlsdeform::Deformer<T> d(rest, s.triangles, rest_handles, o);
        Points<T> out;
        double total = 0;
        for (const PointsD& f : an.frames) {
          moved.points = f.cast<T>();
          const auto t0 = Clock::now();
          d.deform(moved, out);
          total += std::chrono::duration<double>(Clock::now() - t0).count();
        }
        const PointsD x = out.template cast<double>();
        const ShapeQuality q = mlsdeform::testing::shape_quality(s.rest, x, s.triangles);
        const double ms = 1e3 * total / double(an.frames.size()), ratio = judge.energy(x) / ref.energy;
        const std::string label = std::string(warm ? "warm, " : "from MLS, ") + name(a);
        print_row(label, k, ms, ratio, q, quantile(q.rigidity, 0.95) / quantile(qref.rigidity, 0.95));
        json.push_back(json_arap(s, "warm", label, k, ms, ratio, q, quantile(qref.rigidity, 0.95)));
      }
}

// Other poses of the human: frames of data/human_bend.json (a quarter, half, three quarters and all of the
// bend), each from MLS as in the convergence table, against its own converged result.
template <class T>
void poses_table(const Animation& an, const Settings& set, std::vector<std::string>& json) {
  const QualityScene& s = an.scene;
  std::printf(
      "\n### ARAP on other poses: %s\n\n%s: frames 6, 12, 18 and 24 (the bend of the tables above), each from "
      "MLS (Deformer, %s) as in the convergence table; converged: the reference of each pose (double, "
      "Anderson, to a change below 1e-6 per 100 iterations).\n\n"
      "| frame | solver | iterations | ms per frame | energy / E* | rigidity median / p95 | converged median / "
      "p95 |\n|---:|---|---:|---:|---:|---:|---:|\n",
      s.name.c_str(), an.description.c_str(), set.use_double ? "double" : "float");
  mlsdeform::ArapRefiner<double> judge(s.rest, s.triangles, s.handles);
  Handles<T> rest_handles, moved;
  rest_handles.points = rows_of(s.rest, s.handles).cast<T>();
  for (const std::size_t frame : {6, 12, 18, 24}) {
    const PointsD& targets = an.frames[frame - 1];
    const Reference ref = converged(s, targets);
    const ShapeQuality qref = mlsdeform::testing::shape_quality(s.rest, ref.x, s.triangles);
    moved.points = targets.cast<T>();
    const std::pair<ArapAcceleration, int> rows[] = {
        {ArapAcceleration::none, 10}, {ArapAcceleration::anderson, 10}, {ArapAcceleration::anderson, 20}};
    for (const auto& [a, k] : rows) {
      double ms = 0;
      const PointsD x = from_mls(s, set, rest_handles, moved, a, k, ms);
      const ShapeQuality q = mlsdeform::testing::shape_quality(s.rest, x, s.triangles);
      const double ratio = judge.energy(x) / ref.energy;
      std::printf("| %zu | %s | %d | %.3g | %.4f | %.4f / %.4f | %.4f / %.4f |\n", frame, name(a), k, ms, ratio,
                  quantile(q.rigidity, 0.5), quantile(q.rigidity, 0.95), quantile(qref.rigidity, 0.5),
                  quantile(qref.rigidity, 0.95));
      std::fflush(stdout);
      json.push_back(
          json_arap(s, "pose " + std::to_string(frame), name(a), k, ms, ratio, q, quantile(qref.rigidity, 0.95)));
    }
  }
}

}  // namespace

template <class T>
std::vector<std::string> arap_section(const std::vector<QualityScene>& scenes, const Settings& set) {
  std::vector<std::string> json;
  std::printf("\n## ARAP: convergence, acceleration and warm starts\n");
  for (const QualityScene& s : scenes)
    if (s.name == "human" || s.name == "bar" || s.name == "fish") convergence_table<T>(s, set, json);
  for (const QualityScene& s : scenes) {
    if (s.name == "human") warm_table<T>(human_animation(s), set, {2, 5, 10}, json);
    if (s.name == "human") poses_table<T>(human_animation(s), set, json);
    if (s.name == "bar") warm_table<T>(bar_animation(s), set, {2, 5, 10}, json);
  }
  // The human after two Loop subdivisions, the same 8 handles (old vertices keep their indices): the fixed
  // ones at their subdivided rest positions, the moved ones at the animation's targets.
  QualityScene big = human_scene();
  for (int r = 0; r < 2; ++r) loop_subdivide(big.rest, big.triangles);
  const PointsD fixed = rows_of(big.rest, big.handles);
  big.targets.topRows(5) = fixed.topRows(5);
  big.name = "human_loop2";
  Animation an = human_animation(big);
  for (PointsD& f : an.frames) f.topRows(5) = fixed.topRows(5);
  an.description = "data/human_man.obj after two Loop subdivisions, " + std::to_string(big.triangles.rows()) +
                   " triangles, animated by data/human_bend.json";
  warm_table<T>(an, set, {2, 5}, json);
  return json;
}

template std::vector<std::string> arap_section<float>(const std::vector<QualityScene>&, const Settings&);
template std::vector<std::string> arap_section<double>(const std::vector<QualityScene>&, const Settings&);

}  // namespace bench::quality
