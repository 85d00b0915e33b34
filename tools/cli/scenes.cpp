#include "tools/cli/scenes.hpp"

#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>

namespace mlsdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

constexpr double kPi = std::numbers::pi;
double radians(double degrees) { return degrees * kPi / 180.0; }

// Adds quad a b c d, flipped if needed so that its normal points away from `inside`.
void add_quad(Mesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d,
              const Eigen::Vector3d& inside) {
  const Eigen::Vector3d pa = m.vertices.row(a).cast<double>(), pb = m.vertices.row(b).cast<double>(),
                        pc = m.vertices.row(c).cast<double>();
  const Eigen::Vector3d n = (pb - pa).cross(pc - pa);
  if (n.dot(pa - inside) >= 0)
    m.add_face({a, b, c, d});
  else
    m.add_face({d, c, b, a});
}

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

template <class T>
Handles<T> cast(const Handles<double>& h) {
  Handles<T> c;
  c.points = h.points.cast<T>();
  c.segment_a = h.segment_a.cast<T>();
  c.segment_b = h.segment_b.cast<T>();
  return c;
}

}  // namespace

Points<double> to_points(const Mesh& mesh) { return mesh.vertices.cast<double>(); }

Mesh with_vertices(const Mesh& mesh, const Points<double>& vertices) {
  Mesh m = mesh;
  m.vertices = vertices.cast<float>();
  return m;
}

Mesh make_bar(int nx, int ny, int nz, double width, double height) {
  Mesh m;
  const double dx = width / nx, dy = height / ny, dz = width / nz;
  std::vector<std::int64_t> id(std::size_t(nx + 1) * (ny + 1) * (nz + 1), -1);
  auto at = [&](int i, int j, int k) -> std::int64_t& { return id[(std::size_t(j) * (nz + 1) + k) * (nx + 1) + i]; };
  std::vector<Eigen::Vector3f> v;
  for (int j = 0; j <= ny; ++j)
    for (int k = 0; k <= nz; ++k)
      for (int i = 0; i <= nx; ++i)
        if (i == 0 || i == nx || j == 0 || j == ny || k == 0 || k == nz) {
          at(i, j, k) = std::int64_t(v.size());
          v.emplace_back(float(-width / 2 + i * dx), float(j * dy), float(-width / 2 + k * dz));
        }
  m.vertices.resize(Eigen::Index(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) m.vertices.row(Eigen::Index(i)) = v[i].transpose();
  const Eigen::Vector3d centre(0, height / 2, 0);
  auto q = [&](int i0, int j0, int k0, int i1, int j1, int k1, int i2, int j2, int k2, int i3, int j3, int k3) {
    add_quad(m, std::uint32_t(at(i0, j0, k0)), std::uint32_t(at(i1, j1, k1)), std::uint32_t(at(i2, j2, k2)),
             std::uint32_t(at(i3, j3, k3)), centre);
  };
  for (int s : {0, 1}) {
    const int i = s ? nx : 0, j = s ? ny : 0, k = s ? nz : 0;
    for (int a = 0; a < ny; ++a)
      for (int b = 0; b < nz; ++b) q(i, a, b, i, a, b + 1, i, a + 1, b + 1, i, a + 1, b);
    for (int a = 0; a < nx; ++a)
      for (int b = 0; b < nz; ++b) q(a, j, b, a + 1, j, b, a + 1, j, b + 1, a, j, b + 1);
    for (int a = 0; a < nx; ++a)
      for (int b = 0; b < ny; ++b) q(a, b, k, a + 1, b, k, a + 1, b + 1, k, a, b + 1, k);
  }
  return m;
}

Mesh make_plane(int nx, int nz, double sx, double sz) {
  Mesh m;
  m.vertices.resize(Eigen::Index(nx + 1) * (nz + 1), 3);
  for (int k = 0; k <= nz; ++k)
    for (int i = 0; i <= nx; ++i)
      m.vertices.row(Eigen::Index(k) * (nx + 1) + i) << float(-sx / 2 + sx * i / nx), 0.0f,
          float(-sz / 2 + sz * k / nz);
  const auto at = [&](int i, int k) { return std::uint32_t(k * (nx + 1) + i); };
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i) add_quad(m, at(i, k), at(i + 1, k), at(i + 1, k + 1), at(i, k + 1), {0, -1, 0});
  return m;
}

Mesh make_tube(int around, int rings, double radius, double height) {
  Mesh m;
  m.vertices.resize(Eigen::Index(around) * rings, 3);
  for (int r = 0; r < rings; ++r)
    for (int a = 0; a < around; ++a) {
      const double t = 2 * kPi * a / around;
      m.vertices.row(Eigen::Index(r) * around + a) << float(radius * std::cos(t)), float(height * r / (rings - 1)),
          float(radius * std::sin(t));
    }
  for (int r = 0; r + 1 < rings; ++r)
    for (int a = 0; a < around; ++a) {
      const auto i = [&](int rr, int aa) { return std::uint32_t(rr * around + (aa % around)); };
      add_quad(m, i(r, a), i(r, a + 1), i(r + 1, a + 1), i(r + 1, a),
               Eigen::Vector3d(0, height * (r + 0.5) / (rings - 1), 0));
    }
  return m;
}

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

Points<double> weighted_centroids(const Points<double>& vertices, const Handles<double>& rest,
                                  const Handles<double>& moved_h, double u) {
  Points<double> out(vertices.rows(), 3);
  for (Eigen::Index i = 0; i < vertices.rows(); ++i) {
    const Eigen::Vector3d v = vertices.row(i).transpose();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double wsum = 0;
    bool exact = false;
    for (Eigen::Index k = 0; k < rest.point_count() && !exact; ++k) {
      const double d = (rest.points.row(k).transpose() - v).norm();
      if (d == 0) {
        out.row(i) = moved_h.points.row(k);
        exact = true;
        break;
      }
      const double w = std::pow(d, -u);
      sum += w * moved_h.points.row(k).transpose();
      wsum += w;
    }
    for (Eigen::Index k = 0; k < rest.segment_count() && !exact; ++k) {
      const Eigen::Vector3d a = rest.segment_a.row(k).transpose(), b = rest.segment_b.row(k).transpose();
      const double t = std::clamp((v - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      const double d = (a + t * (b - a) - v).norm();
      const Eigen::Vector3d mid = (moved_h.segment_a.row(k) + moved_h.segment_b.row(k)).transpose() / 2;  // Sec. 6.2
      if (d == 0) {
        out.row(i) = mid.transpose();
        exact = true;
        break;
      }
      const double w = std::pow(d, -u);
      sum += w * mid;
      wsum += w;
    }
    if (!exact) out.row(i) = (sum / wsum).transpose();
  }
  return out;
}

Points<double> rbf_centroids(const Points<double>& vertices, const Handles<double>& rest,
                             const Handles<double>& moved_h, double u) {
  const Eigen::Index m = rest.point_count();
  const auto phi = [](double r) { return r; };
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(m + 4, m + 4), rhs = Eigen::MatrixXd::Zero(m + 4, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) M(i, j) = phi((rest.points.row(i) - rest.points.row(j)).norm());
    M(i, m) = M(m, i) = 1;
    for (int c = 0; c < 3; ++c) M(i, m + 1 + c) = M(m + 1 + c, i) = rest.points(i, c);
    rhs.row(i) = moved_h.points.row(i);
  }
  const Eigen::MatrixXd coef = M.completeOrthogonalDecomposition().solve(rhs);
  const Points<double> p_star = weighted_centroids(vertices, rest, rest, u);
  Points<double> out(vertices.rows(), 3);
  for (Eigen::Index v = 0; v < vertices.rows(); ++v) {
    Eigen::RowVector3d g = coef.row(m) + p_star.row(v) * coef.bottomRows(3);
    for (Eigen::Index j = 0; j < m; ++j) g += phi((p_star.row(v) - rest.points.row(j)).norm()) * coef.row(j);
    out.row(v) = g;
  }
  return out;
}

double SceneRun::frames_per_second() const {
  const double total = std::accumulate(frame_seconds.begin(), frame_seconds.end(), 0.0);
  return total > 0 ? double(frame_seconds.size()) / total : 0.0;
}

template <class T>
SceneRun run_scene(const Scene& scene, std::optional<Isa> isa, int threads) {
  SceneRun run;
  Options options = scene.options;
  options.isa = isa;
  options.threads = threads;
  std::vector<Handles<T>> frames;
  frames.reserve(scene.frames.size());
  for (const auto& f : scene.frames) frames.push_back(cast<T>(f));

  Points<T> previous = to_points(scene.mesh).cast<T>(), out(previous.rows(), 3);
  auto t0 = Clock::now();
  Deformer<T> deformer = options.arap_iterations > 0 ? Deformer<T>(previous, fan_triangles(scene.mesh, scene.name),
                                                                   cast<T>(scene.rest), options)
                                                     : Deformer<T>(previous, cast<T>(scene.rest), options);
  run.setup_seconds = seconds_since(t0);
  // One untimed frame first: the first call pays for page faults on `out` and for starting TBB's workers.
  if (!frames.empty()) deformer.deform(frames[0], out);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    if (scene.successive && f > 0) {
      previous.swap(out);
      t0 = Clock::now();
      deformer.reset_rest_pose(previous, frames[f - 1]);
      run.setup_seconds += seconds_since(t0);
    }
    t0 = Clock::now();
    deformer.deform(frames[f], out);
    run.frame_seconds.push_back(seconds_since(t0));
  }
  run.result = frames.empty() ? previous.template cast<double>() : out.template cast<double>();
  return run;
}

template SceneRun run_scene<float>(const Scene&, std::optional<Isa>, int);
template SceneRun run_scene<double>(const Scene&, std::optional<Isa>, int);

}  // namespace mlsdeform::cli
