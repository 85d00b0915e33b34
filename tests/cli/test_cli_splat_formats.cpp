// The program on the compact splat formats (core/files/splat_io.hpp, docs/splats.md "Other formats"): SPZ and
// compressed PLY read and written by name, `.splat` read, a compressed PLY named plainly `.ply` recognised; what
// a format cannot hold refused with exit code 2, naming the splat, and nothing written; what it drops named on
// stderr (refused with --strict-attributes); SPZ's antialiasing flag kept.
#include "core/files/file_io.hpp"
#include "core/files/formats/splat_codecs.hpp"

#include "tests/cli/cli_test_util.hpp"
#include "tests/support/catch.hpp"

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

using cli_test::ScratchDir;
namespace files = mlsdeform::files;

namespace {

const std::string kSeeds = std::string(MLSDEFORM_SOURCE_DIR) + "/tests/fuzz/";

/// A 3DGS PLY of `n` degree-1 splats, with `extra` float properties after the splat ones, every value from
/// `value(splat, property name)`.
std::string splat_ply(std::size_t n, const std::vector<std::string>& extra,
                      float (*value)(std::size_t, const std::string&)) {
  std::vector<std::string> names = {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"};
  for (int k = 0; k < 9; ++k) names.push_back("f_rest_" + std::to_string(k));
  for (const char* s : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"})
    names.push_back(s);
  names.insert(names.end(), extra.begin(), extra.end());
  std::string out = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n) + "\n";
  for (const auto& s : names) out += "property float " + s + "\n";
  out += "end_header\n";
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& s : names) {
      const float v = value(i, s);
      out.append(reinterpret_cast<const char*>(&v), 4);
    }
  return out;
}

float plain(std::size_t i, const std::string& name) {
  if (name == "x") return float(i % 4);
  if (name == "y") return float(i / 4 % 4);
  if (name == "z") return float(i / 16);
  if (name.rfind("scale_", 0) == 0) return -2;
  if (name == "rot_0") return 1;
  if (name.rfind("rot_", 0) == 0) return 0;
  return 0.125f;
}

const char* kHandles = R"({"points": [{"rest": [0, 0, 0]}, {"rest": [3, 0, 0]}, {"rest": [0, 3, 0]},
                                       {"rest": [0, 0, 3], "offset": [0.1, 0, 0]}]})";

}  // namespace

TEST_CASE("Splat formats: SPZ, compressed PLY and .splat in; SPZ and compressed PLY out", "[splat_formats]") {
  ScratchDir dir;
  cli_test::write_text(dir / "h.json", kHandles);
  for (const std::string seed : {"corpus_spz/v4_degree3.spz", "corpus_spz/v3_degree1.spz", "corpus_spz/v2_degree0.spz",
                                 "corpus_splat/three.splat", "corpus_compressed_ply/degree1.compressed.ply"}) {
    INFO(seed);
    for (const std::string out : {"o.ply", "o.spz", "o.compressed.ply"}) {
      const auto r = cli_test::deform(kSeeds + seed, dir / "h.json", dir / out, {"--force"});
      INFO(r.err);
      REQUIRE(r.exit_code == 0);
      CHECK(r.out.find("Gaussian splats") != std::string::npos);
    }
    // The 3DGS PLY output reads back as a splat file of the same splats.
    const std::string ply = cli_test::read_text(dir / "o.ply");
    CHECK(ply.find("property float rot_3\n") != std::string::npos);
  }
  // An animation's frames keep the compound extension: o_0000.compressed.ply, not o.compressed_0000.ply.
  cli_test::write_text(dir / "anim.json", R"({"points": [{"rest": [0, 0, 0]}, {"rest": [3, 0, 0]}],
                                              "frames": [{}, {"points": [null, {"offset": [0, 0.1, 0]}]}]})");
  const auto a = cli_test::deform(kSeeds + "corpus_spz/v4_degree3.spz", dir / "anim.json", dir / "o.compressed.ply");
  INFO(a.err);
  CHECK(a.exit_code == 0);
  CHECK(files::looks_like_compressed_ply(cli_test::read_text(dir / "o_0001.compressed.ply")));
  // A compressed PLY named plainly .ply is read as what it is.
  cli_test::write_text(dir / "plain.ply", cli_test::read_text(kSeeds + "corpus_compressed_ply/degree1.compressed.ply"));
  const auto r = cli_test::deform(dir / "plain.ply", dir / "h.json", dir / "p.spz");
  INFO(r.err);
  CHECK(r.exit_code == 0);
}

TEST_CASE("Splat formats: what a format cannot hold is refused, naming the splat; nothing written", "[splat_formats]") {
  ScratchDir dir;
  cli_test::write_text(dir / "h.json", kHandles);
  cli_test::write_text(dir / "big_sh.ply", splat_ply(20, {}, [](std::size_t i, const std::string& s) {
                         return i == 13 && s == "f_rest_4" ? 1.5f : plain(i, s);
                       }));
  const auto before = dir.files();
  auto r = cli_test::deform(dir / "big_sh.ply", dir / "h.json", dir / "out.spz");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("out.spz: splat 13: f_rest_4 = 1.5") != std::string::npos);
  CHECK(r.err.find("nothing written") != std::string::npos);
  CHECK(dir.files() == before);
  // The same file as compressed PLY (which holds -4 .. 4) and as 3DGS PLY is written.
  CHECK(cli_test::deform(dir / "big_sh.ply", dir / "h.json", dir / "out.compressed.ply").exit_code == 0);
  // .splat is read only; a mesh without splats has nothing to write as SPZ.
  r = cli_test::deform(dir / "big_sh.ply", dir / "h.json", dir / "out.splat");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("read only") != std::string::npos);
  cli_test::write_text(dir / "m.obj", "v 0 0 0\nv 3 0 0\nv 0 3 0\nv 0 0 3\nf 1 2 3\n");
  r = cli_test::deform(dir / "m.obj", dir / "h.json", dir / "m.spz");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("holds Gaussian splats") != std::string::npos);
}

TEST_CASE("Splat formats: what an SPZ output drops is named, or refused with --strict-attributes", "[splat_formats]") {
  ScratchDir dir;
  cli_test::write_text(dir / "h.json", kHandles);
  cli_test::write_text(dir / "n.ply", splat_ply(20, {"nx", "ny", "nz", "confidence"}, plain));
  auto r = cli_test::deform(dir / "n.ply", dir / "h.json", dir / "n.spz");
  CHECK(r.exit_code == 0);
  CHECK(r.err.find("dropped from") != std::string::npos);
  CHECK(r.err.find("vertex properties nx, ny, nz, confidence") != std::string::npos);
  r = cli_test::deform(dir / "n.ply", dir / "h.json", dir / "strict.spz", {"--strict-attributes"});
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("confidence") != std::string::npos);
}

TEST_CASE("Splat formats: SPZ's antialiasing flag passes through the program", "[splat_formats]") {
  ScratchDir dir;
  cli_test::write_text(dir / "h.json", kHandles);
  // One degree-0 splat of version 3 with the flag set (0x1).
  std::string raw = "NGSP";
  for (std::uint32_t v : {3u, 1u}) raw += std::string{char(v), char(v >> 8), char(v >> 16), char(v >> 24)};
  raw += std::string{'\0', char(12), char(1), '\0'};
  raw += std::string(9, '\0') + std::string(1, char(200)) + std::string(3, char(128)) + std::string(3, char(100));
  raw += std::string{'\0', '\0', '\0', char(0xc0)};  // the largest component w (index 3), the others 0
  cli_test::write_text(dir / "a.spz", mlsdeform::files::gzip(raw));
  const auto r = cli_test::deform(dir / "a.spz", dir / "h.json", dir / "b.spz");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const std::string out = cli_test::read_text(dir / "b.spz");
  CHECK(files::decode_spz(out, "b.spz", 1 << 20).antialiased);
}
