// The compact splat codecs (core/files/formats/splat_codecs.hpp, docs/splats.md "Other formats"): SPZ and
// compressed PLY written and read back within each quantity's derived bound, for SH degrees 0-3; every
// truncation and every single-byte change of seed files (written by splat-transform) either read or refused
// with a message naming the file; headers that promise what the data does not hold refused before allocating.
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/formats/splat_codecs.hpp"

#include "tests/cli/cli_test_util.hpp"
#include "tests/support/catch.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>

using mlsdeform::files::InputError;
namespace files = mlsdeform::files;

namespace {

constexpr double eps_f = std::numeric_limits<float>::epsilon();

files::SplatCloud random_cloud(std::size_t n, int degree, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  files::SplatCloud c;
  c.resize(n, degree);
  for (auto& v : c.position) v = 50 * u(rng);
  for (auto& v : c.f_dc) v = 3 * u(rng);
  for (auto& v : c.f_rest) v = 0.99f * u(rng);
  for (auto& v : c.opacity) v = 6 * u(rng);
  for (auto& v : c.scale) v = -4 + 3 * u(rng);
  for (auto& v : c.rot) v = u(rng);
  return c;
}

double sigmoid(double x) { return 1 / (1 + std::exp(-x)); }

/// The rotation angle between two quaternions (w x y z, any length).
double angle(const float* a, const float* b) {
  double na = 0, nb = 0, dot = 0;
  for (int k = 0; k < 4; ++k) na += double(a[k]) * a[k], nb += double(b[k]) * b[k], dot += double(a[k]) * b[k];
  const double c = std::min(1.0, std::fabs(dot) / std::sqrt(na * nb));
  return 2 * std::acos(c);
}

/// docs/splats.md: three components each within h, the largest (>= 1/2) recomputed: a chord of at most
/// 2 sqrt(3) h, an angle of 4 asin(sqrt(3) h).
double rotation_bound(double h) { return 4 * std::asin(std::sqrt(3.0) * h) * 1.001 + 1e-6; }

std::string gz(const std::string& s) { return mlsdeform::files::gzip(s); }

std::string legacy_header(std::uint32_t version, std::uint32_t n, int degree, int flags = 0) {
  std::string h = "NGSP";
  for (std::uint32_t v : {version, n}) h += std::string{char(v), char(v >> 8), char(v >> 16), char(v >> 24)};
  return h + char(degree) + char(12) + char(flags) + '\0';
}

template <class F>
void refused(F&& f, const std::string& fragment) {
  try {
    f();
    FAIL("accepted; expected a refusal mentioning: " << fragment);
  } catch (const InputError& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find(fragment) != std::string::npos);
    CHECK(std::string(e.what()).rfind("t.bin: ", 0) == 0);
  }
}

}  // namespace

TEST_CASE("SPZ: written and read back within each quantity's bound", "[splat_codecs]") {
  for (int degree = 0; degree <= 3; ++degree) {
    INFO("degree " << degree << ", seed " << 10 + degree);
    const files::SplatCloud c = random_cloud(2000, degree, std::uint32_t(10 + degree));
    const files::SplatCloud d = files::decode_spz(files::encode_spz(c, "t.spz"), "t.spz", std::size_t(1) << 30);
    REQUIRE(d.count == c.count);
    REQUIRE(d.sh_degree == degree);
    double pos = 0, rot = 0, scale = 0, dc = 0, alpha = 0, sh = 0;
    for (std::size_t i = 0; i < c.count; ++i) {
      for (std::size_t j = 0; j < 3; ++j) {
        pos = std::max(pos, double(std::fabs(c.position[i * 3 + j] - d.position[i * 3 + j])));
        scale = std::max(scale, double(std::fabs(c.scale[i * 3 + j] - d.scale[i * 3 + j])));
        dc = std::max(dc, double(std::fabs(c.f_dc[i * 3 + j] - d.f_dc[i * 3 + j])));
      }
      alpha = std::max(alpha, std::fabs(sigmoid(c.opacity[i]) - sigmoid(d.opacity[i])));
      rot = std::max(rot, angle(&c.rot[i * 4], &d.rot[i * 4]));
    }
    for (std::size_t k = 0; k < c.f_rest.size(); ++k) sh = std::max(sh, double(std::fabs(c.f_rest[k] - d.f_rest[k])));
    // Each rounded once to its step (a half step), the decoded value then rounded to float.
    CHECK(pos <= std::ldexp(1.0, -13) + 64 * eps_f);
    CHECK(scale <= 1.0 / 32 + 16 * eps_f);
    CHECK(dc <= 0.5 / (0.15 * 255) + 8 * eps_f);
    CHECK(alpha <= 0.5 / 255 + 1e-7);
    CHECK(sh <= 0.5 / 128 + eps_f);
    CHECK(rot <= rotation_bound(0.5 * std::sqrt(0.5) / 511));
    // Version 3's bytes before their gzip layer (what the web page compresses itself) hold the same values.
    const files::SplatCloud p = files::decode_spz(files::encode_spz_payload(c, "t.spz"), "t.spz", 1 << 30);
    CHECK(p.position == d.position);
    CHECK(p.rot == d.rot);
    CHECK(p.f_rest == d.f_rest);
    CHECK(files::decode_spz(gz(files::encode_spz_payload(c, "t.spz")), "t.spz", 1 << 30).scale == d.scale);
  }
}

TEST_CASE("compressed PLY: written and read back within each chunk's bound", "[splat_codecs]") {
  for (int degree = 0; degree <= 3; ++degree) {
    INFO("degree " << degree << ", seed " << 20 + degree);
    files::SplatCloud c = random_cloud(1000, degree, std::uint32_t(20 + degree));
    for (auto& v : c.f_rest) v *= 4;  // the format holds -4 .. 4
    const std::string bytes = files::encode_compressed_ply(c, "t.compressed.ply");
    const files::SplatCloud d = files::decode_compressed_ply(bytes, "t.compressed.ply");
    REQUIRE(d.count == c.count);
    REQUIRE(d.sh_degree == degree);
    for (std::size_t ch = 0; ch * 256 < c.count; ++ch) {
      const std::size_t b = ch * 256, e = std::min(c.count, b + 256);
      double lo[9], hi[9];
      for (int q = 0; q < 9; ++q) lo[q] = INFINITY, hi[q] = -INFINITY;
      for (std::size_t i = b; i < e; ++i)
        for (std::size_t j = 0; j < 3; ++j) {
          const double v[3] = {c.position[i * 3 + j], c.scale[i * 3 + j], c.f_dc[i * 3 + j]};
          for (int q = 0; q < 3; ++q) lo[q * 3 + int(j)] = std::min(lo[q * 3 + int(j)], v[q]);
          for (int q = 0; q < 3; ++q) hi[q * 3 + int(j)] = std::max(hi[q * 3 + int(j)], v[q]);
        }
      for (std::size_t i = b; i < e; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
          const double steps = j == 1 ? 1023 : 2047;
          // Half a step of the chunk's extent, and the lerp's float rounding (a few ulps of the bounds).
          CHECK(std::fabs(c.position[i * 3 + j] - d.position[i * 3 + j]) <=
                (hi[j] - lo[j]) / (2 * steps) + 4 * eps_f * 50);
          CHECK(std::fabs(c.scale[i * 3 + j] - d.scale[i * 3 + j]) <=
                (hi[3 + j] - lo[3 + j]) / (2 * steps) + 4 * eps_f * 8);
          CHECK(std::fabs(c.f_dc[i * 3 + j] - d.f_dc[i * 3 + j]) <= (hi[6 + j] - lo[6 + j]) / 510 + 64 * eps_f);
        }
        CHECK(std::fabs(sigmoid(c.opacity[i]) - sigmoid(d.opacity[i])) <= 0.5 / 255 + 1e-7);
        CHECK(angle(&c.rot[i * 4], &d.rot[i * 4]) <= rotation_bound(0.5 * std::sqrt(2.0) / 1023));
      }
    }
    double sh = 0;
    for (std::size_t k = 0; k < c.f_rest.size(); ++k) sh = std::max(sh, double(std::fabs(c.f_rest[k] - d.f_rest[k])));
    CHECK(sh <= 0.75 / 32 + 8 * eps_f);  // the nearest decoded value: 1/64 inside, 0.75/32 next to +-4
  }
}

TEST_CASE("Splat codecs: every truncation and byte change of the seeds read or refused", "[splat_codecs]") {
  const std::string dir = std::string(MLSDEFORM_SOURCE_DIR) + "/tests/fuzz/";
  const std::vector<std::pair<std::string, files::SplatFormat>> seeds = {
      {"corpus_spz/v2_degree0.spz", files::SplatFormat::spz},
      {"corpus_spz/v3_degree1.spz", files::SplatFormat::spz},
      {"corpus_spz/v4_degree3.spz", files::SplatFormat::spz},
      {"corpus_splat/three.splat", files::SplatFormat::splat},
      {"corpus_compressed_ply/degree1.compressed.ply", files::SplatFormat::compressed_ply}};
  for (const auto& [name, format] : seeds) {
    INFO(name);
    const std::string whole = cli_test::read_text(dir + name);
    auto decode = [&, f = format](const std::string& b) {  // f: a structured binding is not captured by name
      if (f == files::SplatFormat::spz) return files::decode_spz(b, "t.bin", 1 << 20);
      if (f == files::SplatFormat::splat) return files::decode_splat(b, "t.bin");
      return files::decode_compressed_ply(b, "t.bin");
    };
    REQUIRE(decode(whole).count > 0);
    for (std::size_t len = 0; len < whole.size(); ++len) {
      INFO("the first " << len << " bytes");
      if (format == files::SplatFormat::splat && len % 32 == 0 && len > 0) continue;  // whole splats: a file
      REQUIRE_THROWS_AS(decode(whole.substr(0, len)), InputError);
    }
    for (std::size_t at = 0; at < whole.size(); ++at) {
      std::string b = whole;
      b[at] = char(b[at] ^ 0x5a);
      try {
        const files::SplatCloud c = decode(b);
        for (float p : c.position) REQUIRE(std::isfinite(p));
      } catch (const InputError& e) {
        REQUIRE(std::string(e.what()).rfind("t.bin: ", 0) == 0);
      }
    }
    REQUIRE_THROWS_AS(decode(whole + '\0'), InputError);  // nothing may follow
  }
}

TEST_CASE("SPZ: headers that promise what the data does not hold are refused", "[splat_codecs]") {
  const std::string one(9 + 1 + 3 + 3 + 4, '\x40');  // a degree-0 splat of version 3
  const std::size_t mib = 1 << 20;
  CHECK(files::decode_spz(gz(legacy_header(3, 1, 0) + one), "t.bin", mib).count == 1);
  refused([&] { files::decode_spz(gz(legacy_header(3, 2, 0) + one), "t.bin", mib); }, "take");
  refused([&] { files::decode_spz(gz(legacy_header(3, 1, 4) + one), "t.bin", mib); }, "SH degree 4");
  refused([&] { files::decode_spz(gz(legacy_header(1, 1, 0) + one), "t.bin", mib); }, "version 1");
  refused([&] { files::decode_spz(gz(legacy_header(3, 1, 0, 2) + one), "t.bin", mib); }, "extension");
  refused([&] { files::decode_spz(gz(legacy_header(3, 0, 0)), "t.bin", mib); }, "no splats");
  // A count far beyond the data or the limit: refused before anything is allocated for it.
  refused([&] { files::decode_spz(gz(legacy_header(3, 0xffffffffu, 3) + one), "t.bin", mib); }, "input limit");
  refused([&] { files::decode_spz("NGSP", "t.bin", mib); }, "32-byte header");
  refused([&] { files::decode_spz("PK\3\4", "t.bin", mib); }, "neither");
}

TEST_CASE("Splat codecs: values a format cannot hold are refused, naming the splat and the property",
          "[splat_codecs]") {
  auto spz = [](const files::SplatCloud& c) { return files::encode_spz(c, "t.bin"); };
  auto cply = [](const files::SplatCloud& c) { return files::encode_compressed_ply(c, "t.bin"); };
  auto with = [](auto edit) {
    files::SplatCloud c = random_cloud(5, 1, 7);
    for (auto& v : c.f_rest) v *= 0.5f;
    edit(c);
    return c;
  };
  refused([&] { spz(with([](auto& c) { c.f_rest[2 * 9 + 4] = 1.25f; })); }, "splat 2: f_rest_4 = 1.25");
  refused([&] { spz(with([](auto& c) { c.position[3 * 3 + 1] = 3000; })); }, "splat 3: y = 3000");
  refused([&] { spz(with([](auto& c) { c.scale[0] = 7; })); }, "splat 0: scale_0 = 7");
  refused([&] { spz(with([](auto& c) { c.f_dc[4 * 3 + 2] = -4; })); }, "splat 4: f_dc_2 = -4");
  refused([&] { spz(with([](auto& c) { c.opacity[1] = NAN; })); }, "splat 1: opacity");
  refused([&] { spz(with([](auto& c) { c.rot[4] = c.rot[5] = c.rot[6] = c.rot[7] = 0; })); }, "splat 1: rot_0..3");
  refused([&] { cply(with([](auto& c) { c.scale[3 * 3] = -25; })); }, "splat 3: scale_0 = -25");
  refused([&] { cply(with([](auto& c) { c.f_rest[9 + 8] = 4.5f; })); }, "splat 1: f_rest_8 = 4.5");
  refused([&] { cply(with([](auto& c) { c.position[2] = INFINITY; })); }, "splat 0: z");
  refused([&] { cply(files::SplatCloud{}); }, "no splats");
}
