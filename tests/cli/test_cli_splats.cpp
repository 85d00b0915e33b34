// The program on 3D Gaussian splat files (core/files/splats.cpp, docs/splats.md): a rigid or similarity motion of
// every handle turns each splat's rot_* by that rotation and shifts its scale_* by log(s), to the fit's bound,
// rotates its f_rest_*, and passes every other property through bit for bit; a region leaves the splats outside
// it bit for bit; an affine fit maps each splat by its centre's matrix; splats on point and segment handles turn
// with the motion; files that are splat files only in part, and values a float property cannot hold after the
// turn, are refused.
#include "tests/cli/cli_test_util.hpp"
#include "tests/support/accuracy_bounds.hpp"
#include "tests/support/deform_cases.hpp"
#include "tests/support/mls_reference.hpp"
#include "tests/support/splats.hpp"

#include <mlsdeform/splats.hpp>

#include "tests/support/catch.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

using cli_test::ScratchDir;
using L = long double;
namespace testing = mlsdeform::testing;

namespace {

constexpr std::size_t kPer = 62;  // float properties of a degree-3 splat
constexpr L eps_f = std::numeric_limits<float>::epsilon();

/// The handles: the bar's eight corners at each end, two layers each, so that every fit sees a 3D spread.
std::vector<Eigen::Vector3d> handle_rests() {
  std::vector<Eigen::Vector3d> p;
  for (double z : {0.0, 0.1, 1.9, 2.0})
    for (double x : {-0.2, 0.2})
      for (double y : {-0.2, 0.2}) p.emplace_back(x, y, z);
  return p;
}

std::string handles_json(const std::vector<Eigen::Vector3d>& rest, const std::vector<Eigen::Vector3d>& target,
                         const std::string& extra = {}) {
  std::string s = "{\"points\": [";
  char buf[256];
  for (std::size_t j = 0; j < rest.size(); ++j) {
    std::snprintf(buf, sizeof buf, "%s{\"rest\": [%.17g, %.17g, %.17g], \"target\": [%.17g, %.17g, %.17g]}",
                  j ? ", " : "", rest[j].x(), rest[j].y(), rest[j].z(), target[j].x(), target[j].y(), target[j].z());
    s += buf;
  }
  return s + "]" + extra + "}";
}

/// The records of a splat file written by the program: its header must be the input's but for comment lines
/// (the writer names itself in one), its body the records.
std::vector<float> records(const std::string& bytes, const std::string& header, std::size_t n) {
  const std::size_t end = bytes.find("end_header\n");
  REQUIRE(end != std::string::npos);
  std::string lines;
  for (std::size_t at = 0; at < end + 11;) {
    const std::size_t next = bytes.find('\n', at) + 1;
    if (bytes.compare(at, 8, "comment ") != 0) lines += bytes.substr(at, next - at);
    at = next;
  }
  REQUIRE(lines == header);
  REQUIRE(bytes.size() == end + 11 + n * kPer * 4);
  std::vector<float> r(n * kPer);
  std::memcpy(r.data(), bytes.data() + end + 11, r.size() * 4);
  return r;
}

struct Motion {
  Eigen::Matrix3d R;
  double s;
  Eigen::Vector3d pivot, t;
  Eigen::Vector3d operator()(const Eigen::Vector3d& x) const { return s * (R * (x - pivot)) + pivot + t; }
};

}  // namespace

TEST_CASE("splats: a rigid or similarity motion of every handle turns and grows every splat by it", "[cli][splats]") {
  ScratchDir dir;
  const testing::SplatCloud cloud = testing::random_splat_cloud(1500, 17);
  testing::write_splat_ply(dir / "in.ply", cloud);
  const std::string header = testing::splat_ply_header(cloud.n, 3);
  const std::vector<float> in = records(cli_test::read_text(dir / "in.ply"), header, cloud.n);
  const std::vector<Eigen::Vector3d> rest = handle_rests();
  for (const bool similarity : {false, true}) {
    INFO("similarity " << similarity);
    const Motion m{Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix(),
                   similarity ? 1.5 : 1.0, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.3, -0.2, 0.1)};
    std::vector<Eigen::Vector3d> target;
    for (const auto& p : rest) target.push_back(m(p));
    cli_test::write_text(dir / "h.json", handles_json(rest, target));
    const auto r = cli_test::deform(dir / "in.ply", dir / "h.json", dir / "out.ply",
                                    {"-f", "--transform", similarity ? "similarity" : "rigid"});
    REQUIRE(r.exit_code == 0);
    CHECK(r.out.find("splats") != std::string::npos);
    const std::vector<float> out = records(cli_test::read_text(dir / "out.ply"), header, cloud.n);
    const Eigen::Quaternion<L> qR(m.R.cast<L>());
    const double qr[4] = {double(qR.w()), double(qR.x()), double(qR.y()), double(qR.z())};
    // The handles as the program holds them (float), for the reference's bound at each splat.
    mlsdeform::Points<double> p_rest(Eigen::Index(rest.size()), 3), p_moved(Eigen::Index(rest.size()), 3);
    for (std::size_t j = 0; j < rest.size(); ++j) {
      p_rest.row(Eigen::Index(j)) = rest[j].transpose();
      p_moved.row(Eigen::Index(j)) = target[j].transpose();
    }
    const mlsdeform::Handles<float> h_rest = testing::point_handles<float>(p_rest),
                                    h_moved = testing::point_handles<float>(p_moved);
    mlsdeform::Points<float> centres(Eigen::Index(cloud.n), 3);
    for (std::size_t i = 0; i < cloud.n; ++i)
      for (int k = 0; k < 3; ++k) centres(Eigen::Index(i), k) = cloud.positions[3 * i + std::size_t(k)];
    const double l = testing::scene_size(centres, h_rest);
    mlsdeform::Options options;
    options.transform = similarity ? mlsdeform::Transform::similarity : mlsdeform::Transform::rigid;
    std::vector<double> expected_sh(cloud.f_rest.begin(), cloud.f_rest.end());
    for (std::size_t i = 0; i < cloud.n; ++i) {
      // The same f_rest_* turned by the exact rotation, in double (the library's own, held to the colour property
      // in tests/test_splats.cpp): this test checks which values the program takes, turns and stores.
      std::vector<double> q(4);
      std::copy(qr, qr + 4, q.begin());
      const mlsdeform::SplatArrays<double> a{nullptr, nullptr, expected_sh.data() + 45 * i, 3};
      mlsdeform::rotate_splats<double>(a, 1, q.data());
    }
    for (std::size_t i = 0; i < cloud.n; ++i) {
      const float* o = out.data() + kPer * i;
      const float* p = in.data() + kPer * i;
      INFO("splat " << i);
      // nx ny nz (zeros stay zeros), f_dc_*, opacity: as read, bit for bit
      CHECK(std::memcmp(o + 3, p + 3, 6 * 4) == 0);
      CHECK(std::memcmp(o + 54, p + 54, 4) == 0);
      // The frame's quaternion is off R's by tol_q (tests/test_frames.cpp's derivation from the reference's
      // bound, mls_reference.hpp: |dR|_F <= 2 (|dH|_F + 16 eps |H|_F) / gap plus R's departure from
      // orthonormality; the quaternion moves by half that, plus the departure again and 10 eps of rounding).
      // Composing with the splat's quaternion is an isometry; rounding q' to float adds eps.
      const testing::DirectVertex dv = testing::direct_vertex(Eigen::Vector3d(double(p[0]), double(p[1]), double(p[2])),
                                                              h_rest, h_moved, options, l);
      REQUIRE((dv.well_posed && !dv.snapped));
      const double eps = double(eps_f), orth = 1.5 * double(testing::c_o) * eps;
      const double tol_q = (2 * (dv.dH_unit + 16 * dv.norm_H) * eps / dv.gap + orth) / 2 + orth + 10 * eps;
      const Eigen::Quaternion<L> q_in(p[58], p[59], p[60], p[61]), q_out(o[58], o[59], o[60], o[61]);
      const Eigen::Quaternion<L> expected = (qR * q_in.normalized()).normalized();
      const L sign = expected.dot(q_out) < 0 ? -1 : 1;
      const L dq = (expected.coeffs() - sign * q_out.coeffs()).norm();
      CHECK(dq <= tol_q + eps);
      CHECK(std::abs(q_out.norm() - 1) <= 2 * eps_f);
      // scale_*: + log(s), s (Sec. 6.1's mu) off by |dmu| <= mu (J + 16) eps + (sqrt(3) |dH|_F + 16 eps |H|_F) / D
      // (test_frames.cpp), so log s by |dmu| / mu; rounding to float adds eps |log s'|.
      const double tol_log =
          similarity ? ((dv.mu * (16 + 16) + (std::sqrt(3.0) * dv.dH_unit + 16 * dv.norm_H) / dv.D) * eps) / dv.mu : 0;
      for (int k = 0; k < 3; ++k) {
        const L expected_log = L(p[55 + k]) + std::log(L(m.s));
        CHECK(std::abs(L(o[55 + k]) - expected_log) <= tol_log + eps_f * std::abs(expected_log));
      }
      // The rotation's angle is off by at most 2 asin(tol_q) <= 2.1 tol_q.
      const L bound = 2.1L * tol_q;
      // f_rest_*: a band-l rotation matrix moves by at most l theta for a rotation error theta (its generators'
      // eigenvalues are -l..l), so by 3 x bound; rounding to float eps_f / 2 relative; the library's own
      // computation 2 x 2,600 eps_d (once here, once in the program).
      L norm = 0;
      for (int j = 0; j < 45; ++j) norm += L(p[9 + j]) * L(p[9 + j]);
      norm = std::sqrt(norm);
      const L sh_bound = (3 * bound + eps_f + 5200 * L(std::numeric_limits<double>::epsilon())) * norm;
      for (std::size_t j = 0; j < 45; ++j) CHECK(std::abs(L(o[9 + j]) - L(expected_sh[45 * i + j])) <= sh_bound);
    }
  }
}

TEST_CASE("splats: outside a region every splat keeps every bit", "[cli][splats]") {
  ScratchDir dir;
  const testing::SplatCloud cloud = testing::random_splat_cloud(400, 23);
  testing::write_splat_ply(dir / "in.ply", cloud);
  const std::string header = testing::splat_ply_header(cloud.n, 3);
  const std::vector<float> in = records(cli_test::read_text(dir / "in.ply"), header, cloud.n);
  const std::vector<Eigen::Vector3d> rest = handle_rests();
  std::vector<Eigen::Vector3d> target = rest;
  for (std::size_t j = 8; j < 16; ++j) target[j] += Eigen::Vector3d(0.3, 0, 0);  // the top end pushed sideways
  std::string region = ", \"region\": [";
  std::vector<bool> inside(cloud.n);
  for (std::size_t i = 0; i < cloud.n; ++i)
    if ((inside[i] = cloud.positions[3 * i + 2] > 1.0f))
      region += (region.back() == '[' ? "" : ", ") + std::to_string(i);
  cli_test::write_text(dir / "h.json", handles_json(rest, target, region + "]"));
  const auto r = cli_test::deform(dir / "in.ply", dir / "h.json", dir / "out.ply");
  REQUIRE(r.exit_code == 0);
  const std::vector<float> out = records(cli_test::read_text(dir / "out.ply"), header, cloud.n);
  std::size_t turned = 0;
  for (std::size_t i = 0; i < cloud.n; ++i) {
    const bool same = std::memcmp(out.data() + kPer * i, in.data() + kPer * i, kPer * 4) == 0;
    if (!inside[i]) CHECK(same);
    turned += !same;
  }
  CHECK(turned > 0);  // the region's splats did move and turn
}

TEST_CASE("splats: an affine fit maps each splat by the matrix the library fits at its centre", "[cli][splats]") {
  // The program's part: it takes each centre's FramesOut::linear (held to the motion's matrix in
  // tests/test_frames_affine.cpp) and the splat's rot_*, scale_*, f_rest_* as read, maps them by
  // transform_splats_affine in double (held to M Sigma M^T in tests/test_splats_affine.cpp) and stores them in
  // float: the same library calls here give the same bits.
  ScratchDir dir;
  const testing::SplatCloud cloud = testing::random_splat_cloud(300, 29);
  testing::write_splat_ply(dir / "in.ply", cloud);
  const std::string header = testing::splat_ply_header(cloud.n, 3);
  const std::vector<float> in = records(cli_test::read_text(dir / "in.ply"), header, cloud.n);
  const std::vector<Eigen::Vector3d> rest = handle_rests();
  Eigen::Matrix3d A;
  A << 1.2, 0.4, 0, 0, 0.9, 0.1, 0.2, 0, 1.1;  // a shear and a stretch
  std::vector<Eigen::Vector3d> target;
  for (const auto& p : rest) target.push_back(A * p + Eigen::Vector3d(0.3, -0.2, 0.1));
  cli_test::write_text(dir / "h.json", handles_json(rest, target));
  const auto r = cli_test::deform(dir / "in.ply", dir / "h.json", dir / "out.ply", {"--transform", "affine"});
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("splats") != std::string::npos);
  const std::vector<float> out = records(cli_test::read_text(dir / "out.ply"), header, cloud.n);
  mlsdeform::Points<double> p_rest(Eigen::Index(rest.size()), 3), p_moved(Eigen::Index(rest.size()), 3);
  for (std::size_t j = 0; j < rest.size(); ++j) {
    p_rest.row(Eigen::Index(j)) = rest[j].transpose();
    p_moved.row(Eigen::Index(j)) = target[j].transpose();
  }
  mlsdeform::Points<float> centres(Eigen::Index(cloud.n), 3);
  for (std::size_t i = 0; i < cloud.n; ++i)
    for (int k = 0; k < 3; ++k) centres(Eigen::Index(i), k) = cloud.positions[3 * i + std::size_t(k)];
  mlsdeform::Options options;
  options.transform = mlsdeform::Transform::affine;
  options.affine_frames = true;  // as the program sets it for a splat file
  const mlsdeform::Deformer<float> d(centres, testing::point_handles<float>(p_rest), options);
  mlsdeform::Points<float> moved;
  std::vector<float> linear(9 * cloud.n);
  d.deform(testing::point_handles<float>(p_moved), moved, mlsdeform::FramesOut<float>{{}, {}, {}, linear});
  for (std::size_t i = 0; i < cloud.n; ++i) {
    INFO("splat " << i);
    const float* p = in.data() + kPer * i;
    const float* o = out.data() + kPer * i;
    std::vector<double> rot(p + 58, p + 62), scale(p + 55, p + 58), sh(p + 9, p + 54), m(9);
    std::copy_n(linear.data() + 9 * i, 9, m.begin());
    mlsdeform::transform_splats_affine<double>({rot.data(), scale.data(), sh.data(), 3}, 1, m.data());
    for (int k = 0; k < 4; ++k) CHECK(o[58 + k] == float(rot[std::size_t(k)]));
    for (int k = 0; k < 3; ++k) CHECK(o[55 + k] == float(scale[std::size_t(k)]));
    for (int k = 0; k < 45; ++k) CHECK(o[9 + k] == float(sh[std::size_t(k)]));
    CHECK(std::memcmp(o + 3, p + 3, 6 * 4) == 0);  // nx ny nz (zeros), f_dc_*: as read
    CHECK(std::memcmp(o + 54, p + 54, 4) == 0);    // opacity
    // Not the identity: the covariance was mapped.
    CHECK(std::memcmp(o + 55, p + 55, 7 * 4) != 0);
  }
}

TEST_CASE("splats: files that are splat files only in part are refused", "[cli][splats]") {
  ScratchDir dir;
  const testing::SplatCloud cloud = testing::random_splat_cloud(50, 29);
  testing::write_splat_ply(dir / "in.ply", cloud);
  const std::vector<Eigen::Vector3d> rest = handle_rests();
  cli_test::write_text(dir / "h.json", handles_json(rest, rest));
  // rot_3 renamed: a splat file in part
  std::string bytes = cli_test::read_text(dir / "in.ply");
  const std::size_t at = bytes.find("property float rot_3\n");
  REQUIRE(at != std::string::npos);
  bytes.replace(at, 20, "property float rot_x");
  cli_test::write_text(dir / "half.ply", bytes);
  const auto r = cli_test::deform(dir / "half.ply", dir / "h.json", dir / "out.ply");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("half.ply") != std::string::npos);
  CHECK(r.err.find("rot_3") != std::string::npos);
}

TEST_CASE("splats: each frame of an animation turns the rest pose's splats", "[cli][splats]") {
  ScratchDir dir;
  const testing::SplatCloud cloud = testing::random_splat_cloud(300, 31);
  testing::write_splat_ply(dir / "in.ply", cloud);
  const std::vector<Eigen::Vector3d> rest = handle_rests();
  const Motion m{Eigen::AngleAxisd(0.5, Eigen::Vector3d(0, 1, 0)).toRotationMatrix(), 1.0, Eigen::Vector3d(0, 0, 1),
                 Eigen::Vector3d::Zero()};
  // Two frames with the same targets: the second must not turn the splats the first already turned.
  std::string frame = "{\"points\": [";
  char buf[128];
  for (std::size_t j = 0; j < rest.size(); ++j) {
    const Eigen::Vector3d t = m(rest[j]);
    std::snprintf(buf, sizeof buf, "%s[%.17g, %.17g, %.17g]", j ? ", " : "", t.x(), t.y(), t.z());
    frame += buf;
  }
  frame += "]}";
  cli_test::write_text(dir / "h.json", handles_json(rest, rest, ", \"frames\": [" + frame + ", " + frame + "]"));
  const auto r = cli_test::deform(dir / "in.ply", dir / "h.json", dir / "out.ply", {"-q"});
  REQUIRE(r.exit_code == 0);
  const std::string first = cli_test::read_text(dir / "out_0000.ply"),
                    second = cli_test::read_text(dir / "out_0001.ply");
  records(first, testing::splat_ply_header(cloud.n, 3), cloud.n);  // every property kept
  CHECK(first == second);
  CHECK(first != cli_test::read_text(dir / "in.ply"));
}

TEST_CASE("splats: splats on point and segment handles turn with the motion too", "[cli][splats]") {
  ScratchDir dir;
  const testing::SplatCloud cloud = testing::random_splat_cloud(400, 37);
  testing::write_splat_ply(dir / "in.ply", cloud);
  const std::vector<Eigen::Vector3d> rest = handle_rests();
  const Motion m{Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix(), 1.0,
                 Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.3, -0.2, 0.1)};
  std::vector<Eigen::Vector3d> target;
  for (const auto& p : rest) target.push_back(m(p));
  // Splat 0 a point handle, splats 1 and 2 the ends of a segment handle, all moved with the rest: the library's
  // frame there is the fit's limit at the handle, the same motion.
  auto moved = [&](std::size_t i) {
    const Eigen::Vector3d t =
        m(Eigen::Vector3d(cloud.positions[3 * i], cloud.positions[3 * i + 1], cloud.positions[3 * i + 2]));
    char buf[96];
    std::snprintf(buf, sizeof buf, "[%.17g, %.17g, %.17g]", t.x(), t.y(), t.z());
    return std::string(buf);
  };
  std::string json = handles_json(rest, target);
  json.replace(json.size() - 2, 2,
               ", {\"vertex\": 0, \"target\": " + moved(0) + "}], \"segments\": [{\"vertices\": [1, 2], \"target\": [" +
                   moved(1) + ", " + moved(2) + "]}]}");
  cli_test::write_text(dir / "h.json", json);
  for (const char* weight : {"constant", "exact"}) {
    INFO("--segment-weight " << weight);
    const auto r =
        cli_test::deform(dir / "in.ply", dir / "h.json", dir / "out.ply", {"-f", "--segment-weight", weight});
    INFO(r.err);
    REQUIRE(r.exit_code == 0);
    const std::vector<float> out =
        records(cli_test::read_text(dir / "out.ply"), testing::splat_ply_header(cloud.n, 3), cloud.n);
    const Eigen::Quaternion<L> qR(m.R.cast<L>());
    for (std::size_t i = 0; i < 3; ++i) {
      INFO("splat " << i);
      const float* r_in = cloud.rotations.data() + 4 * i;
      const Eigen::Quaternion<L> q_in(r_in[0], r_in[1], r_in[2], r_in[3]);
      const float* o = out.data() + kPer * i + 58;
      const Eigen::Quaternion<L> q_out(o[0], o[1], o[2], o[3]);
      // The frame at a handle is the same rigid motion to the fit's bound (about 1e-5 here, test 1's
      // figures): 1e-3 tells it from the identity, or the segment's own rank-1 fit, which leave it far off.
      CHECK(2 * std::acos(std::min(L(1), std::abs((qR * q_in.normalized()).dot(q_out)))) < 1e-3L);
    }
  }
}

TEST_CASE("splats: a value its float property cannot hold after the turn is refused, nothing written",
          "[cli][splats][errors]") {
  // Splat 5's band-1 coefficients of the red channel (f_rest_0..2: y, z, x) are (a, 0, a), a = 0.9 x float's
  // largest: an eighth of a turn about z takes (a, a) to (0, sqrt(2) a) up to signs and order, beyond float;
  // a turn of 0.05 rad to at most (cos 0.05 + sin 0.05) a < 0.95 x float's largest, within it.
  ScratchDir dir;
  testing::SplatCloud cloud = testing::random_splat_cloud(50, 41, 1);
  const float a = 0.9f * std::numeric_limits<float>::max();
  cloud.f_rest[9 * 5 + 0] = a;
  cloud.f_rest[9 * 5 + 1] = 0;
  cloud.f_rest[9 * 5 + 2] = a;
  testing::write_splat_ply(dir / "in.ply", cloud);
  const std::vector<Eigen::Vector3d> rest = handle_rests();
  const Motion m{Eigen::AngleAxisd(std::numbers::pi / 4, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1.0,
                 Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::Zero()};
  std::vector<Eigen::Vector3d> target;
  for (const auto& p : rest) target.push_back(m(p));
  cli_test::write_text(dir / "h.json", handles_json(rest, target));
  const auto r = cli_test::deform(dir / "in.ply", dir / "h.json", dir / "out.ply", {"-q"});
  INFO(r.err);
  CHECK(r.exit_code == 2);
  CHECK(cli_test::line_count(r.err) == 1);
  CHECK(r.err.find("mlsdeform: error: " + dir / "in.ply" + ": splat (vertex) 5: its f_rest_") == 0);
  CHECK(r.err.find("beyond the range of float, the property's type") != std::string::npos);
  CHECK(!std::filesystem::exists(dir / "out.ply"));
  const Motion small{Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1.0,
                     Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::Zero()};
  target.clear();
  for (const auto& p : rest) target.push_back(small(p));
  cli_test::write_text(dir / "h.json", handles_json(rest, target));
  const auto fits = cli_test::deform(dir / "in.ply", dir / "h.json", dir / "out.ply", {"-q"});
  CHECK(fits.exit_code == 0);
  CHECK(fits.err.empty());
  const std::string bytes = cli_test::read_text(dir / "out.ply");
  const std::size_t body = bytes.find("end_header\n") + 11, per = 3 + 3 + 3 + 9 + 1 + 3 + 4;  // degree 1
  REQUIRE(bytes.size() == body + cloud.n * per * 4);
  for (std::size_t j = 0; j < 9; ++j) {
    float c;
    std::memcpy(&c, bytes.data() + body + (5 * per + 9 + j) * 4, 4);
    CHECK(std::isfinite(c));
  }
}
