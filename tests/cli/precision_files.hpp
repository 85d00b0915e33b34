// The precision tests' inputs, written by hand (not by the program's writer): OBJ, OFF and PLY texts of given
// double coordinates, handles files, and the checks of what the program wrote back.
#pragma once

#include "tests/cli/cli_test_util.hpp"

#include "core/files/mesh.hpp"

#include "tests/support/catch.hpp"

#include <Eigen/Core>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

namespace precision_test {

using mlsdeform::PointsRowMajor;

template <class R>
std::string shortest(R v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

using Rows = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// Three faces on 8 vertices (a triangle, a quad and a triangle sharing an edge with it).
inline const std::vector<std::vector<int>> kFaces{{0, 1, 2}, {3, 4, 5, 6}, {5, 6, 7}};

inline std::string obj_text(const Rows& v) {
  std::string s = "# test\n";
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    s += "v " + shortest(v(i, 0)) + " " + shortest(v(i, 1)) + " " + shortest(v(i, 2)) + "\n";
  for (const auto& f : kFaces) {
    s += "f";
    for (int c : f) s.append(" ").append(std::to_string(c + 1));
    s += "\n";
  }
  return s;
}

inline std::string off_text(const Rows& v) {
  std::string s = "OFF\n" + std::to_string(v.rows()) + " " + std::to_string(kFaces.size()) + " 0\n";
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    s += shortest(v(i, 0)) + " " + shortest(v(i, 1)) + " " + shortest(v(i, 2)) + "\n";
  for (const auto& f : kFaces) {
    s += std::to_string(f.size());
    for (int c : f) s.append(" ").append(std::to_string(c));
    s += "\n";
  }
  return s;
}

// A PLY file with `type` ("float" or "double") x, y, z, written by hand (not by the program's writer).
inline std::string ply_text(const Rows& v, bool binary, const std::string& type) {
  std::string s = "ply\nformat " + std::string(binary ? "binary_little_endian" : "ascii") + " 1.0\nelement vertex " +
                  std::to_string(v.rows()) + "\nproperty " + type + " x\nproperty " + type + " y\nproperty " + type +
                  " z\nelement face " + std::to_string(kFaces.size()) +
                  "\nproperty list uchar int vertex_indices\nend_header\n";
  static_assert(std::endian::native == std::endian::little);
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      if (binary && type == "double") {
        s.append(reinterpret_cast<const char*>(&v(i, k)), 8);
      } else if (binary) {
        const float f = float(v(i, k));
        s.append(reinterpret_cast<const char*>(&f), 4);
      } else {
        s.append(k ? " " : "").append(type == "double" ? shortest(v(i, k)) : shortest(float(v(i, k))));
        if (k == 2) s += "\n";
      }
    }
  for (const auto& f : kFaces) {
    if (binary) {
      s.push_back(char(f.size()));
      for (int c : f) s.append(reinterpret_cast<const char*>(&c), 4);
    } else {
      s += std::to_string(f.size());
      for (int c : f) s.append(" ").append(std::to_string(c));
      s += "\n";
    }
  }
  return s;
}

// Every vertex a point handle that stays at rest.
inline std::string all_handles(Eigen::Index n) {
  std::string s = R"({"points": [)";
  for (Eigen::Index i = 0; i < n; ++i) s += (i ? ", " : "") + std::string(R"({"vertex": )") + std::to_string(i) + "}";
  return s + "]}";
}

// 8 coordinates triples with full 53-bit mantissas and random signs, of magnitude about 10^e.
inline Rows random_points(std::mt19937_64& rng, int e) {
  Rows v(8, 3);
  std::uniform_real_distribution<double> mantissa(1.0, 10.0);
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    for (int k = 0; k < 3; ++k) v(i, k) = (rng() & 1 ? -1 : 1) * mantissa(rng) * std::pow(10.0, e);
  return v;
}

// The `v` lines of an OBJ text.
inline std::vector<std::string> v_lines(const std::string& obj) {
  std::vector<std::string> lines;
  std::size_t i = 0;
  while (i < obj.size()) {
    const std::size_t j = std::min(obj.find('\n', i), obj.size());
    if (obj.compare(i, 2, "v ") == 0) lines.push_back(obj.substr(i, j - i));
    i = j + 1;
  }
  return lines;
}

inline void require_bitwise(const Rows& expected, const PointsRowMajor<double>& actual) {
  REQUIRE(actual.rows() == expected.rows());
  for (Eigen::Index i = 0; i < expected.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      INFO("vertex " << i << " coordinate " << k << ": expected " << shortest(expected(i, k)) << ", got "
                     << shortest(actual(i, k)));
      REQUIRE(std::bit_cast<std::uint64_t>(actual(i, k)) == std::bit_cast<std::uint64_t>(expected(i, k)));
    }
}

inline cli_test::Result deform(const std::vector<std::string>& args) {
  std::vector<std::string> all{"deform", "-q", "--force"};
  all.insert(all.end(), args.begin(), args.end());
  return cli_test::run(cli_test::program, all);
}

}  // namespace precision_test
