// See primitives.hpp.
#include "tools/cli/primitives.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace mlsdeform::cli {
namespace {

constexpr double kPi = std::numbers::pi;

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

}  // namespace mlsdeform::cli
