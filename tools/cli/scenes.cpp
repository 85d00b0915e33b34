// See scenes.hpp.
#include "tools/cli/scenes.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

namespace mlsdeform::cli {
namespace {

constexpr double kPi = std::numbers::pi;
double radians(double degrees) { return degrees * kPi / 180.0; }

// Moves the rows of `p` by x -> R (x - pivot) + pivot + shift.
Points<double> moved(const Points<double>& p, const Eigen::Matrix3d& R, const Eigen::Vector3d& pivot,
                     const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  Points<double> q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    q.row(i) = (R * (p.row(i).transpose() - pivot) + pivot + shift).transpose();
  return q;
}

Points<double> rows_of(const Points<double>& p, const std::vector<Eigen::Index>& idx) {
  Points<double> q(Eigen::Index(idx.size()), 3);
  for (std::size_t i = 0; i < idx.size(); ++i) q.row(Eigen::Index(i)) = p.row(idx[i]);
  return q;
}

Handles<double> points_only(Points<double> p) {
  Handles<double> h;
  h.points = std::move(p);
  h.segment_a.resize(0, 3);
  h.segment_b.resize(0, 3);
  return h;
}

}  // namespace

Scene human_bend_scene(const Mesh& human, int frames, double degrees, Transform transform) {
  Scene s;
  s.name = "human";
  s.mesh = human;
  s.options.transform = transform;
  const Points<double> v = to_points(human);
  const Eigen::Index n = v.rows();
  if (n == 0) throw std::invalid_argument("human_bend_scene: empty mesh");
  // Handles by landmark: top of the head, the two finger tips (T pose), toes and heels of each foot.
  auto best = [&](auto score, auto keep) {
    Eigen::Index arg = -1;
    double top = -HUGE_VAL;
    for (Eigen::Index i = 0; i < n; ++i)
      if (keep(v.row(i)) && score(v.row(i)) > top) {
        top = score(v.row(i));
        arg = i;
      }
    if (arg < 0) throw std::invalid_argument("human_bend_scene: landmark not found");
    return arg;
  };
  const double floor = v.col(1).minCoeff(), height = v.col(1).maxCoeff() - floor;
  auto any = [](const auto&) { return true; };
  auto foot = [&](int side) {
    return [&, side](const auto& p) { return p(1) < floor + 0.06 * height && side * p(0) > 0; };
  };
  const Eigen::Index head = best([](const auto& p) { return p(1); }, any);
  const Eigen::Index left_hand = best([](const auto& p) { return -p(0); }, any);
  const Eigen::Index right_hand = best([](const auto& p) { return p(0); }, any);
  const Eigen::Index toes[2] = {best([](const auto& p) { return p(2); }, foot(-1)),
                                best([](const auto& p) { return p(2); }, foot(1))};
  const Eigen::Index heels[2] = {best([](const auto& p) { return -p(2); }, foot(-1)),
                                 best([](const auto& p) { return -p(2); }, foot(1))};
  const std::vector<Eigen::Index> moving = {head, left_hand, right_hand};
  const std::vector<Eigen::Index> fixed = {toes[0], toes[1], heels[0], heels[1]};
  std::vector<Eigen::Index> all = moving;
  all.insert(all.end(), fixed.begin(), fixed.end());
  s.rest = points_only(rows_of(v, all));
  const Eigen::Vector3d waist(0, floor + 0.56 * height, 0);
  // The hands end in front of the knees, a third of their span apart: not a rigid motion of the handles, so
  // that the three kinds of transform differ (Fig. 1).
  const double span = v(right_hand, 0) - v(left_hand, 0);
  const Eigen::Vector3d hand_goal[2] = {{-span / 6, floor + 0.3 * height, 0.25 * height},
                                        {span / 6, floor + 0.3 * height, 0.25 * height}};
  for (int f = 1; f <= frames; ++f) {
    const double t = double(f) / frames;
    const Eigen::Matrix3d R = Eigen::AngleAxisd(radians(degrees * t), Eigen::Vector3d::UnitX()).toRotationMatrix();
    Points<double> q = s.rest.points;
    q.row(0) = moved(v.row(head), R, waist);
    q.row(1) = (1 - t) * v.row(left_hand) + t * hand_goal[0].transpose();
    q.row(2) = (1 - t) * v.row(right_hand) + t * hand_goal[1].transpose();
    s.frames.push_back(points_only(q));
  }
  s.description = "human (data/human_man.obj) bending " + std::to_string(int(degrees)) +
                  " degrees forward, hands to the knees, feet fixed";
  return s;
}

Scene human_arap_scene(const Mesh& human) {
  struct Pin {
    Eigen::Index vertex;
    Eigen::Vector3d target;
  };
  // The first five stay at their rest positions (these are those positions); the last three move.
  const Pin pins[] = {{1337, {0.007005, 1.053843, 0.171833}},
                      {3215, {0.078112, 0.019384, 0.180523}},
                      {3386, {0.095968, 0.039844, -0.085711}},
                      {6618, {-0.086231, 0.01583, 0.179475}},
                      {6786, {-0.098815, 0.041748, -0.090276}},
                      {411, {0.00213, 1.38829, 0.68933}},
                      {5906, {-0.3, 0.55, 0.45}},
                      {2445, {0.3, 0.55, 0.45}}};
  Scene s;
  s.name = "human_arap";
  s.mesh = human;
  const Points<double> v = to_points(human);
  std::vector<Eigen::Index> at;
  Points<double> q(Eigen::Index(std::size(pins)), 3);
  for (const Pin& p : pins) {
    if (p.vertex >= v.rows()) throw std::invalid_argument("human_arap_scene: not the bundled human (too few vertices)");
    q.row(Eigen::Index(at.size())) = p.target.transpose();
    at.push_back(p.vertex);
  }
  s.rest = points_only(rows_of(v, at));
  s.frames.push_back(points_only(q));
  s.description = "human (data/human_man.obj) bent forward by 8 point handles (data/human_bend.json's last frame)";
  return s;
}

Scene bar_twist_scene(int steps, double degrees) {
  Scene s;
  s.name = "bar_twist";
  constexpr int nx = 16, ny = 88, nz = 16;
  const double width = 1.0, height = 5.5;
  s.mesh = make_bar(nx, ny, nz, width, height);
  const Points<double> v = to_points(s.mesh);
  // Handles: the side vertices of the two outermost rings at each end: 4 rings of 64 = Table 2's 256.
  std::vector<Eigen::Index> bottom, top;
  const double dy = height / ny, half = width / 2;
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    const int j = int(std::lround(v(i, 1) / dy));
    const bool side = std::abs(std::abs(v(i, 0)) - half) < 1e-6 || std::abs(std::abs(v(i, 2)) - half) < 1e-6;
    if (!side) continue;
    if (j <= 1) bottom.push_back(i);
    if (j >= ny - 1) top.push_back(i);
  }
  std::vector<Eigen::Index> all = bottom;
  all.insert(all.end(), top.begin(), top.end());
  s.rest = points_only(rows_of(v, all));
  const auto nb = Eigen::Index(bottom.size());
  for (int f = 1; f <= steps; ++f) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(radians(degrees * f / steps), Eigen::Vector3d::UnitY()).toRotationMatrix();
    Points<double> q = s.rest.points;
    q.bottomRows(q.rows() - nb) = moved(rows_of(v, top), R, Eigen::Vector3d::Zero());
    s.frames.push_back(points_only(q));
  }
  s.successive = true;
  s.description = "bar (Table 2: 6146 vertices, 256 handles) twisted " + std::to_string(int(degrees)) + " degrees in " +
                  std::to_string(steps) + " successive torsions";
  return s;
}

Scene cylinder_scene(double u, int frames, double degrees) {
  Scene s;
  s.name = "cylinder";
  constexpr int around = 23, rings = 46, group = 7;
  const double radius = 0.5, height = 3.0;
  s.mesh = make_tube(around, rings, radius, height);
  const Points<double> v = to_points(s.mesh);
  std::vector<Eigen::Index> bottom, top;
  for (int r = 0; r < group; ++r)
    for (int a = 0; a < around; ++a) {
      bottom.push_back(Eigen::Index(r) * around + a);
      top.push_back(Eigen::Index(rings - group + r) * around + a);
    }
  std::vector<Eigen::Index> all = bottom;
  all.insert(all.end(), top.begin(), top.end());
  s.rest = points_only(rows_of(v, all));
  s.options.weight_exponent = u;
  const Eigen::Vector3d pivot(0, height * (rings - 1 - (group - 1) / 2.0) / (rings - 1), 0);  // centre of the top group
  for (int f = 1; f <= frames; ++f) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(radians(degrees * f / frames), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    Points<double> q = s.rest.points;
    q.bottomRows(Eigen::Index(top.size())) = moved(rows_of(v, top), R, pivot);
    s.frames.push_back(points_only(q));
  }
  char u_text[16];
  std::snprintf(u_text, sizeof u_text, "%g", u);
  s.description = "cylinder (Table 2: 1058 vertices, 322 handles), top group rotated " + std::to_string(int(degrees)) +
                  " degrees, u = " + u_text;
  return s;
}

Scene bar_bend_scene(int variant, int frames) {
  Scene s;
  constexpr int nx = 8, ny = 48, nz = 8;
  const double w = 1.0, L = 6.0;
  s.mesh = make_bar(nx, ny, nz, w, L);
  // The top end's motion at time t in [0, 1]: rotated by -t 90 degrees about z (the bar's axis turns from +y
  // towards +x) and moved to where bending the whole bar into a circular arc of that angle would put it.
  auto top_motion = [&](double t, const Points<double>& p) {
    const double a = t * kPi / 2;
    const Eigen::Matrix3d Ra = Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const double r = a > 0 ? L / a : 0;
    const Eigen::Vector3d end =
        a > 0 ? Eigen::Vector3d(r - r * std::cos(a), r * std::sin(a), 0) : Eigen::Vector3d(0, L, 0);
    return moved(p, Ra, Eigen::Vector3d(0, L, 0), end - Eigen::Vector3d(0, L, 0));
  };
  Handles<double> rest;
  rest.segment_a.resize(0, 3);
  rest.segment_b.resize(0, 3);
  Eigen::Index moving_from = 0;  // rows of points (or segments) at the top end start here
  if (variant == 0) {
    s.name = "bend_points_few";
    // Two points at each end, across the bar.
    rest.points.resize(4, 3);
    rest.points << -w / 2, 0, 0, w / 2, 0, 0, -w / 2, L, 0, w / 2, L, 0;
    moving_from = 2;
    s.description = "bar bent 90 degrees with 4 point handles";
  } else if (variant == 1) {
    s.name = "bend_points_many";
    // The corners and edge midpoints of each end face, at each end and a quarter of the way in.
    std::vector<Eigen::Vector3d> ring;
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b)
        if (a || b) ring.emplace_back(a * w / 2, 0, b * w / 2);
    const double levels[4] = {0, L / 8, L - L / 8, L};
    rest.points.resize(Eigen::Index(4 * ring.size()), 3);
    for (int l = 0; l < 4; ++l)
      for (std::size_t i = 0; i < ring.size(); ++i)
        rest.points.row(Eigen::Index(l * ring.size() + i)) = (ring[i] + Eigen::Vector3d(0, levels[l], 0)).transpose();
    moving_from = Eigen::Index(2 * ring.size());
    s.description = "bar bent 90 degrees with 32 point handles";
  } else {
    s.name = "bend_segments";
    // At each end, two segments along opposite side edges, an eighth of the bar long: as few primitives as
    // (a) has points, and each pins down a direction.
    rest.segment_a.resize(4, 3);
    rest.segment_b.resize(4, 3);
    rest.segment_a << -w / 2, 0, 0, w / 2, 0, 0, -w / 2, L - L / 8, 0, w / 2, L - L / 8, 0;
    rest.segment_b << -w / 2, L / 8, 0, w / 2, L / 8, 0, -w / 2, L, 0, w / 2, L, 0;
    rest.points.resize(0, 3);
    moving_from = 2;
    s.description = "bar bent 90 degrees with 4 segment handles";
  }
  s.rest = rest;
  for (int f = 1; f <= frames; ++f) {
    const double t = double(f) / frames;
    Handles<double> q = rest;
    if (variant < 2) {
      q.points.bottomRows(q.points.rows() - moving_from) =
          top_motion(t, rest.points.bottomRows(rest.points.rows() - moving_from));
    } else {
      q.segment_a.bottomRows(2) = top_motion(t, rest.segment_a.bottomRows(2));
      q.segment_b.bottomRows(2) = top_motion(t, rest.segment_b.bottomRows(2));
    }
    s.frames.push_back(q);
  }
  return s;
}

Scene fish_scene(const Mesh& fish) {
  Scene s;
  s.name = "fish";
  s.mesh = fish;
  const Points<double> v = to_points(fish);
  if (v.rows() == 0) throw std::invalid_argument("fish_scene: empty mesh");
  Eigen::Index mouth, tail, fin, belly;
  v.col(2).maxCoeff(&mouth);
  v.col(2).minCoeff(&tail);
  v.col(1).maxCoeff(&fin);
  v.col(1).minCoeff(&belly);
  s.rest = points_only(rows_of(v, {mouth, tail, fin, belly}));
  // The head and the tail turn upwards about points a third of the way in from each end, on the body's axis.
  const double front = v.col(2).maxCoeff(), back = v.col(2).minCoeff(), length = front - back;
  const Eigen::Vector3d centre = (v.colwise().minCoeff() + v.colwise().maxCoeff()).transpose() / 2;
  const Eigen::Vector3d head_pivot(centre.x(), centre.y(), front - length / 3),
      tail_pivot(centre.x(), centre.y(), back + length / 3);
  const Eigen::Matrix3d up_front = Eigen::AngleAxisd(radians(-25), Eigen::Vector3d::UnitX()).toRotationMatrix(),
                        up_back = Eigen::AngleAxisd(radians(40), Eigen::Vector3d::UnitX()).toRotationMatrix();
  Points<double> q = s.rest.points;
  q.row(0) = moved(v.row(mouth), up_front, head_pivot);
  q.row(1) = moved(v.row(tail), up_back, tail_pivot);
  s.frames.push_back(points_only(q));
  s.description = "fish (fish.obj) flexed by 4 point handles";
  return s;
}

Scene plane_translate_scene() {
  Scene s;
  s.name = "plane_translate";
  constexpr int n = 32;
  const double size = 2.0;
  s.mesh = make_plane(n, n, size, size);
  const Points<double> v = to_points(s.mesh);
  std::vector<Eigen::Index> fixed, moving;
  for (int k = 0; k <= n; ++k) {
    fixed.push_back(Eigen::Index(k) * (n + 1));
    fixed.push_back(Eigen::Index(k) * (n + 1) + n);
    moving.push_back(Eigen::Index(k) * (n + 1) + n / 2);
  }
  std::vector<Eigen::Index> all = fixed;
  all.insert(all.end(), moving.begin(), moving.end());
  s.rest = points_only(rows_of(v, all));
  Points<double> q = s.rest.points;
  q.bottomRows(Eigen::Index(moving.size())).rowwise() += Eigen::RowVector3d(0, 0, 0.25 * size);
  s.frames.push_back(points_only(q));
  s.description =
      "plane (Table 2: 1089 vertices): its middle column of handles translated along itself, the sides fixed";
  return s;
}

Scene bar_far_scene() {
  Scene s;
  s.name = "bar_far";
  constexpr int nx = 8, ny = 48, nz = 8;
  const double w = 1.0, L = 6.0;
  s.mesh = make_bar(nx, ny, nz, w, L);
  std::vector<Eigen::Vector3d> ring;
  for (int a = -1; a <= 1; ++a)
    for (int b = -1; b <= 1; ++b)
      if (a || b) ring.emplace_back(a * w / 2, 0, b * w / 2);
  const double levels[4] = {0, L / 8, L - L / 8, L};
  Points<double> p(Eigen::Index(4 * ring.size()), 3);
  for (int l = 0; l < 4; ++l)
    for (std::size_t i = 0; i < ring.size(); ++i)
      p.row(Eigen::Index(l * ring.size() + i)) = (ring[i] + Eigen::Vector3d(0, levels[l], 0)).transpose();
  s.rest = points_only(p);
  Points<double> q = p;
  q.bottomRows(Eigen::Index(2 * ring.size())).rowwise() += Eigen::RowVector3d(0.9 * L, -0.5 * L, 0);
  s.frames.push_back(points_only(q));
  s.description = "bar (1666 vertices): its upper end translated sideways and down by 1.03 bar lengths";
  return s;
}

Scene plane_row_scene(Centroids centroids) {
  Scene s;
  s.name = centroids == Centroids::rbf ? "plane_row_rbf" : "plane_row";
  constexpr int n = 32;
  const double size = 2.0;
  s.mesh = make_plane(n, n, size, size);
  s.options.centroids = centroids;
  const Points<double> v = to_points(s.mesh);
  std::vector<Eigen::Index> fixed, row;
  for (int k = 0; k <= n; ++k) {
    fixed.push_back(Eigen::Index(k) * (n + 1));
    fixed.push_back(Eigen::Index(k) * (n + 1) + n);
  }
  for (int k = n / 2 - 8; k <= n / 2 + 8; k += 4) row.push_back(Eigen::Index(k) * (n + 1) + n / 2);
  std::vector<Eigen::Index> all = fixed;
  all.insert(all.end(), row.begin(), row.end());
  s.rest = points_only(rows_of(v, all));
  Points<double> q = s.rest.points;
  q.bottomRows(Eigen::Index(row.size())).rowwise() += Eigen::RowVector3d(0, 0.5 * size, 0);
  s.frames.push_back(points_only(q));
  s.description = "plane (Table 2: 1089 vertices): a row of 5 handles raised, the side columns fixed";
  return s;
}

}  // namespace mlsdeform::cli
