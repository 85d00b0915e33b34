// twist_bar: the paper's Fig. 3. A generated bar (the paper's Bar: 6,146 vertices, 256 constraints) is
// twisted about its long axis by successive small torsions: each step turns every handle by a small
// angle proportional to its position along the bar, deforms, and takes the result as the new rest pose
// (Deformer::reset_rest_pose), so that a total twist far beyond what one MLS step can follow is built
// from steps it follows easily. Writes the result as OBJ (vertices and triangles).
//
//   twist_bar [out.obj] [--steps N] [--degrees TOTAL] [--transform rigid|similarity|affine]
//             [--method axis_angle|horn_quaternion|horn_matrix|kanatani|svd] [--exponent U] [--threads N]
#include <mlsdeform/mlsdeform.hpp>

#include <Eigen/Geometry>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

namespace {

using mlsdeform::Points;

/// The surface of an a x b x c grid box (cells of size h), x in [0, a h]: (a+1)(b+1)(c+1) - (a-1)(b-1)(c-1)
/// vertices; 188 x 8 x 8 gives the paper's 6,146. Triangles: two per boundary cell face, outward normals.
struct GridBar {
  Points<double> vertices;
  std::vector<std::array<int, 3>> triangles;
  int a, b, c;
  std::vector<int> index;  // grid (i, j, k) -> vertex, -1 inside
  int at(int i, int j, int k) const { return index[(std::size_t(i) * (b + 1) + j) * (c + 1) + k]; }
};

GridBar grid_bar(int a, int b, int c, double h) {
  GridBar bar{{}, {}, a, b, c, std::vector<int>(std::size_t(a + 1) * (b + 1) * (c + 1), -1)};
  std::vector<Eigen::Vector3d> v;
  for (int i = 0; i <= a; ++i)
    for (int j = 0; j <= b; ++j)
      for (int k = 0; k <= c; ++k)
        if (i == 0 || i == a || j == 0 || j == b || k == 0 || k == c) {
          bar.index[(std::size_t(i) * (b + 1) + j) * (c + 1) + k] = int(v.size());
          // Centred on the x axis.
          v.emplace_back(i * h, (j - 0.5 * b) * h, (k - 0.5 * c) * h);
        }
  bar.vertices.resize(Eigen::Index(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) bar.vertices.row(Eigen::Index(i)) = v[i].transpose();
  // A quad p0 p1 p2 p3 (counter-clockwise seen from outside) as two triangles.
  auto quad = [&](int p0, int p1, int p2, int p3) {
    bar.triangles.push_back({p0, p1, p2});
    bar.triangles.push_back({p0, p2, p3});
  };
  for (int i = 0; i < a; ++i)
    for (int j = 0; j < b; ++j) {
      quad(bar.at(i, j, 0), bar.at(i, j + 1, 0), bar.at(i + 1, j + 1, 0), bar.at(i + 1, j, 0));  // z = min, -z
      quad(bar.at(i, j, c), bar.at(i + 1, j, c), bar.at(i + 1, j + 1, c), bar.at(i, j + 1, c));  // z = max, +z
    }
  for (int i = 0; i < a; ++i)
    for (int k = 0; k < c; ++k) {
      quad(bar.at(i, 0, k), bar.at(i + 1, 0, k), bar.at(i + 1, 0, k + 1), bar.at(i, 0, k + 1));  // y = min, -y
      quad(bar.at(i, b, k), bar.at(i, b, k + 1), bar.at(i + 1, b, k + 1), bar.at(i + 1, b, k));  // y = max, +y
    }
  for (int j = 0; j < b; ++j)
    for (int k = 0; k < c; ++k) {
      quad(bar.at(0, j, k), bar.at(0, j, k + 1), bar.at(0, j + 1, k + 1), bar.at(0, j + 1, k));  // x = 0, -x
      quad(bar.at(a, j, k), bar.at(a, j + 1, k), bar.at(a, j + 1, k + 1), bar.at(a, j, k + 1));  // x = max, +x
    }
  return bar;
}

/// 256 handles on bar vertices: 16 cross-sections along the bar, 16 points around each (every other
/// vertex of the section's boundary ring).
std::vector<int> make_handles(const GridBar& bar) {
  std::vector<std::array<int, 2>> jk;  // (j, k) around the boundary of the b x c section
  for (int j = 0; j < bar.b; ++j) jk.push_back({j, 0});
  for (int k = 0; k < bar.c; ++k) jk.push_back({bar.b, k});
  for (int j = bar.b; j > 0; --j) jk.push_back({j, bar.c});
  for (int k = bar.c; k > 0; --k) jk.push_back({0, k});
  std::vector<int> handles;
  for (int s = 0; s < 16; ++s) {
    const int i = int(std::lround(s * bar.a / 15.0));
    for (std::size_t r = 0; r < jk.size(); r += jk.size() / 16) handles.push_back(bar.at(i, jk[r][0], jk[r][1]));
  }
  return handles;
}

bool write_obj(const std::string& path, const Points<double>& v, const std::vector<std::array<int, 3>>& tris) {
  std::ofstream out(path);
  if (!out) return false;
  out << "# twist_bar (mlsdeform): " << v.rows() << " vertices, " << tris.size() << " triangles\n";
  char line[96];
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", v(i, 0), v(i, 1), v(i, 2));
    out << line;
  }
  for (const auto& t : tris) out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  return bool(out);
}

[[noreturn]] void usage(const char* msg) {
  std::fprintf(stderr,
               "twist_bar: %s\nusage: twist_bar [out.obj] [--steps N] [--degrees TOTAL] "
               "[--transform rigid|similarity|affine] [--method NAME] [--exponent U] [--threads N]\n",
               msg);
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) try {
  std::string path = "twist_bar.obj";
  int steps = 12;
  double degrees = 360;
  mlsdeform::Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(("missing value after " + arg).c_str());
      return argv[++i];
    };
    if (arg == "--steps")
      steps = std::stoi(value());
    else if (arg == "--degrees")
      degrees = std::stod(value());
    else if (arg == "--transform") {
      const std::string t = value();
      if (t == "rigid")
        options.transform = mlsdeform::Transform::rigid;
      else if (t == "similarity")
        options.transform = mlsdeform::Transform::similarity;
      else if (t == "affine")
        options.transform = mlsdeform::Transform::affine;
      else
        usage(("unknown transform " + t).c_str());
    } else if (arg == "--method")
      options.method = mlsdeform::rotation_method_from_string(value());
    else if (arg == "--exponent")
      options.weight_exponent = std::stod(value());
    else if (arg == "--threads")
      options.threads = std::stoi(value());
    else if (arg == "-h" || arg == "--help")
      usage("twists a generated bar by successive small torsions (paper Fig. 3)");
    else if (!arg.empty() && arg[0] == '-')
      usage(("unknown option " + arg).c_str());
    else
      path = arg;
  }
  if (steps < 1) usage("--steps must be >= 1");

  const GridBar bar = grid_bar(188, 8, 8, 0.125);  // 23.5 x 1 x 1
  const std::vector<int> handle_vertices = make_handles(bar);
  const double length = bar.a * 0.125;
  mlsdeform::Handles<double> handles;
  handles.points.resize(Eigen::Index(handle_vertices.size()), 3);
  for (std::size_t h = 0; h < handle_vertices.size(); ++h)
    handles.points.row(Eigen::Index(h)) = bar.vertices.row(handle_vertices[h]);
  std::printf("twist_bar: bar %gx1x1, %ld vertices, %zu triangles, %ld point handles (16 sections x 16)\n", length,
              long(bar.vertices.rows()), bar.triangles.size(), long(handles.points.rows()));
  std::printf("           %s MLS, u = %g, rotation fit %s; %d torsions of %g degrees (total %g) about the x axis\n",
              options.transform == mlsdeform::Transform::rigid        ? "rigid"
              : options.transform == mlsdeform::Transform::similarity ? "similarity"
                                                                      : "affine",
              options.weight_exponent, std::string(mlsdeform::to_string(options.method)).c_str(), steps,
              degrees / steps, degrees);

  Points<double> current = bar.vertices, out;
  mlsdeform::Deformer<double> deformer(current, handles, options);
  std::printf("           precomputation: %.1f MiB (%.0f bytes per vertex and handle)\n",
              double(deformer.memory_bytes()) / (1 << 20),
              double(deformer.memory_bytes()) / double(current.rows() * handles.points.rows()));
  double total_ms = 0;
  for (int s = 0; s < steps; ++s) {
    // One small torsion: a handle at x turns by (degrees / steps) * x / length about the bar's axis.
    mlsdeform::Handles<double> moved = handles;
    for (Eigen::Index h = 0; h < handles.points.rows(); ++h) {
      const Eigen::Vector3d p = handles.points.row(h).transpose();
      const double angle = degrees / steps * M_PI / 180 * p.x() / length;
      moved.points.row(h) = (Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX()) * p).transpose();
    }
    const auto t0 = std::chrono::steady_clock::now();
    deformer.deform(moved, out);
    const auto t1 = std::chrono::steady_clock::now();
    total_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
    current = out;
    handles = moved;
    if (s + 1 < steps) deformer.reset_rest_pose(current, handles);  // the next torsion starts from here
  }
  // What the twist did to the far end: the angle of its cross-section's corner ring.
  const int far = bar.at(bar.a, 0, 0), near = bar.at(0, 0, 0);
  const double turned =
      std::atan2(current(far, 2), current(far, 1)) - std::atan2(bar.vertices(far, 2), bar.vertices(far, 1));
  const double near_moved = (current.row(near) - bar.vertices.row(near)).norm();
  double remainder = std::remainder(turned * 180 / M_PI - degrees, 360.0);
  std::printf(
      "           deform: %.1f ms per torsion (%d); far end turned by %g degrees (mod 360: %+.2g off), "
      "near end moved %.2g\n",
      total_ms / steps, steps, degrees, remainder, near_moved);
  if (!write_obj(path, current, bar.triangles)) {
    std::fprintf(stderr, "twist_bar: cannot write %s\n", path.c_str());
    return 1;
  }
  std::printf("           wrote %s\n", path.c_str());
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "twist_bar: %s\n", e.what());
  return 1;
}
