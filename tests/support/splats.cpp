#include "tests/support/splats.hpp"

#include "tests/support/random.hpp"

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <numbers>
#include <stdexcept>

namespace mlsdeform::testing {

SplatCloud random_splat_cloud(std::size_t n, std::uint64_t seed, int sh_degree, float length) {
  if (sh_degree < 0 || sh_degree > 3) throw std::invalid_argument("random_splat_cloud: sh_degree not in 0..3");
  Rng rng(seed);
  SplatCloud c;
  c.n = n;
  c.sh_degree = sh_degree;
  const std::size_t k = std::size_t(3 * ((sh_degree + 1) * (sh_degree + 1) - 1));
  c.positions.resize(3 * n);
  c.normals.assign(3 * n, 0.0f);
  c.f_dc.resize(3 * n);
  c.f_rest.resize(k * n);
  c.opacity.resize(n);
  c.log_scales.resize(3 * n);
  c.rotations.resize(4 * n);
  const double w = length / 10.0, base = std::log(length / 100.0);
  for (std::size_t i = 0; i < n; ++i) {
    c.positions[3 * i] = float(rng.uniform<double>(-w, w));
    c.positions[3 * i + 1] = float(rng.uniform<double>(-w, w));
    c.positions[3 * i + 2] = float(rng.uniform<double>(0, length));
    for (std::size_t j = 0; j < 3; ++j) c.f_dc[3 * i + j] = float(rng.gaussian<double>());
    for (std::size_t j = 0; j < k; ++j) c.f_rest[k * i + j] = float(0.1 * rng.gaussian<double>());
    c.opacity[i] = float(rng.gaussian<double>());
    for (std::size_t j = 0; j < 3; ++j) c.log_scales[3 * i + j] = float(base + 0.5 * rng.gaussian<double>());
    double q[4], norm = 0;
    for (double& x : q) {
      x = rng.gaussian<double>();
      norm += x * x;
    }
    const double to = rng.uniform<double>(0.5, 2.0) / std::sqrt(norm);
    for (std::size_t j = 0; j < 4; ++j) c.rotations[4 * i + j] = float(q[j] * to);
  }
  return c;
}

std::string splat_ply_header(std::size_t n, int sh_degree) {
  std::string h = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n) + "\n";
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"})
    h += std::string("property float ") + p + "\n";
  const int k = 3 * ((sh_degree + 1) * (sh_degree + 1) - 1);
  for (int j = 0; j < k; ++j) h += "property float f_rest_" + std::to_string(j) + "\n";
  for (const char* p : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    h += std::string("property float ") + p + "\n";
  return h + "end_header\n";
}

std::vector<char> splat_ply_bytes(const SplatCloud& c) {
  const std::string header = splat_ply_header(c.n, c.sh_degree);
  const std::size_t k = c.n ? c.f_rest.size() / c.n : 0, per = 3 + 3 + 3 + k + 1 + 3 + 4;
  std::vector<float> record(per);
  std::vector<char> bytes(header.begin(), header.end());
  bytes.reserve(header.size() + c.n * per * sizeof(float));
  static_assert(std::endian::native == std::endian::little, "the generator writes the host's floats as they are");
  for (std::size_t i = 0; i < c.n; ++i) {
    float* r = record.data();
    auto put = [&r](const std::vector<float>& a, std::size_t first, std::size_t count) {
      std::memcpy(r, a.data() + first, count * sizeof(float));
      r += count;
    };
    put(c.positions, 3 * i, 3);
    put(c.normals, 3 * i, 3);
    put(c.f_dc, 3 * i, 3);
    put(c.f_rest, k * i, k);
    put(c.opacity, i, 1);
    put(c.log_scales, 3 * i, 3);
    put(c.rotations, 4 * i, 4);
    const char* b = reinterpret_cast<const char*>(record.data());
    bytes.insert(bytes.end(), b, b + per * sizeof(float));
  }
  return bytes;
}

void write_splat_ply(const std::string& path, const SplatCloud& cloud) {
  const std::vector<char> bytes = splat_ply_bytes(cloud);
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  if (!out) throw std::runtime_error("write_splat_ply: cannot write " + path);
}

std::string bent_bar_handles() {
  std::string json = "{\"points\": [";
  const double c = std::cos(std::numbers::pi / 3), s = std::sin(std::numbers::pi / 3);
  for (double z : {0.0, 0.1, 1.9, 2.0})
    for (double x : {-0.2, 0.2})
      for (double y : {-0.2, 0.2}) {
        double ty = y, tz = z;
        if (z > 1) ty = c * y - s * (z - 1.5), tz = 1.5 + s * y + c * (z - 1.5);
        char buf[200];
        std::snprintf(buf, sizeof buf, "%s{\"rest\": [%g, %g, %g], \"target\": [%.17g, %.17g, %.17g]}",
                      json.back() == '[' ? "" : ", ", x, y, z, x, ty, tz);
        json += buf;
      }
  return json + "]}\n";
}

}  // namespace mlsdeform::testing
