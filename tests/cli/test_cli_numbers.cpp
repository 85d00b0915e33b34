// The portable twins of the floating-point std::from_chars / std::to_chars (core/files/formats/numbers.hpp),
// which the mesh readers and writers use where the standard library lacks them (the web page's module), held
// against the standard library's own on this build: the same consumed prefix, the same errc and bitwise the
// same value for every string (no tolerance: both are correctly rounded, so any difference is a bug), and the
// formatter's text equal to std::to_chars's and read back bit for bit.
#include "core/files/formats/numbers.hpp"

#include "tests/support/catch.hpp"

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace {

using mlsdeform::files::formats::portable_from_chars;
using mlsdeform::files::formats::portable_to_chars;

template <class R>
using Bits = std::conditional_t<sizeof(R) == 4, std::uint32_t, std::uint64_t>;

// Same bits, or both NaN with the same sign (the payload of "nan(chars)" is the C library's business).
template <class R>
bool same(R a, R b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b) && std::signbit(a) == std::signbit(b);
  return std::bit_cast<Bits<R>>(a) == std::bit_cast<Bits<R>>(b);
}

template <class R>
void check_parse(const std::string& s) {
  const char* first = s.data();
  const char* last = s.data() + s.size();
  R expected = R(-7.25), got = R(-7.25);  // out_of_range and invalid_argument leave the value as it was
  const auto e = std::from_chars(first, last, expected);
  const auto g = portable_from_chars(first, last, got);
  INFO("'" << s << "' as " << (sizeof(R) == 4 ? "float" : "double"));
  REQUIRE(g.ptr - first == e.ptr - first);
  REQUIRE(g.ec == e.ec);
  REQUIRE(same(got, expected));
}

template <class R>
void check_format(R v) {
  char e[64], g[64];
  const auto er = std::to_chars(e, e + sizeof e, v);
  char* const gend = portable_to_chars(g, g + sizeof g, v);
  REQUIRE(gend != nullptr);
  const std::string expected(e, er.ptr), got(g, gend);
  INFO(std::hexfloat << double(v) << " as " << (sizeof(R) == 4 ? "float" : "double"));
  REQUIRE(got == expected);
  R back = 0;
  const auto r = std::from_chars(g, gend, back);
  REQUIRE(r.ec == std::errc());
  REQUIRE(same(back, v));
}

// Strings around the edges of the grammar and of the ranges.
std::vector<std::string> edge_strings() {
  std::vector<std::string> s = {"",
                                "-",
                                "+1",
                                ".",
                                "-.",
                                "e5",
                                "1e",
                                "1e+",
                                "1e-",
                                "1.e5",
                                ".5e-3",
                                "1.5.5",
                                "0x1p3",
                                "0x10",
                                "1e5x",
                                "--1",
                                " 1",
                                "1 ",
                                "00012.50",
                                "-0",
                                "0e999999",
                                "-0.0e-999",
                                "inf",
                                "-Infinity",
                                "INF",
                                "infin",
                                "infinityx",
                                "nan",
                                "-NaN",
                                "nan(abc_12)",
                                "nan(",
                                "nan()",
                                "nan(a-b)",
                                "in",
                                "n",
                                "1e39",
                                "-1e39",
                                "3.4028235e38",
                                "3.40282356e38",
                                "3.4028236e38",
                                "1.7976931348623157e308",
                                "1.7976931348623159e308",
                                "1e309",
                                "1e-46",
                                "7e-46",
                                "7.1e-46",
                                "1.4e-45",
                                "1e-45",
                                "1.17549435e-38",
                                "1.1754942e-38",
                                "1e-320",
                                "4.9406564584124654e-324",
                                "2.4703282292062328e-324",
                                "2.4703282292062327e-324",
                                "1e-324",
                                "1e-400",
                                "1e99999999999999999999",
                                "1e-99999999999999999999",
                                "123456789012345678901234567890",
                                "0.000000000000000000000000000000001e32",
                                "9007199254740993",
                                "9007199254740992.5",
                                "0.1000000000000000055511151231257827021181583404541015625",
                                "0.10000000149011611938476562500000000000000000000000000000000000000000000000000001"};
  std::string long_mantissa = "1.";
  for (int i = 0; i < 800; ++i) long_mantissa += char('0' + (i * 7) % 10);
  s.push_back(long_mantissa);
  s.push_back(long_mantissa + "e-300");
  return s;
}

// Exactly halfway between two adjacent floats, written out in full (a double holds the midpoint exactly), and
// a hair either side: round-half-even and the sticky digits far down the mantissa.
void add_halfway(std::vector<std::string>& s, float a) {
  const float b = std::nextafter(a, std::numeric_limits<float>::infinity());
  const double mid = (double(a) + double(b)) / 2;
  char buf[1200];
  std::snprintf(buf, sizeof buf, "%.1000g", mid);
  std::string exact = buf;
  if (exact.find('.') == std::string::npos && exact.find('e') == std::string::npos) exact += ".0";
  s.push_back(exact);
  if (exact.find('e') == std::string::npos) {
    s.push_back(exact + "0000000000000000000000000000001");
    std::string below = exact;
    for (std::size_t i = below.size(); i-- > 0;) {  // the last non-zero digit down by one, nines after it
      if (below[i] >= '1' && below[i] <= '9') {
        below[i] = char(below[i] - 1);
        below += "99999999999999999999999999";
        break;
      }
    }
    s.push_back(below);
  }
}

}  // namespace

TEST_CASE("numbers: the portable parser matches std::from_chars on edge strings", "[cli][numbers]") {
  auto strings = edge_strings();
  for (const float a : {1.0f, 0.1f, 3.0e38f, std::numeric_limits<float>::max(), std::numeric_limits<float>::min(),
                        std::numeric_limits<float>::denorm_min(), 1.5e-40f, 16777216.0f, 1e10f})
    add_halfway(strings, a);
  for (const auto& s : strings) {
    check_parse<float>(s);
    check_parse<double>(s);
  }
}

TEST_CASE("numbers: the portable parser matches std::from_chars on random numbers", "[cli][numbers]") {
  std::mt19937_64 rng(20261125);
  char buf[128];
  for (int i = 0; i < 20000; ++i) {
    // Any bit pattern (subnormals, NaN, infinities included), written with 1 to 25 significant digits in each
    // layout, so that the text lands anywhere between two floats or doubles.
    const auto bits = rng();
    const double d = std::bit_cast<double>(bits);
    const float f = std::bit_cast<float>(std::uint32_t(bits >> 32));
    const int p = int(rng() % 25) + 1;
    for (const double v : {d, double(f)}) {
      for (const char* fmt : {"%.*e", "%.*g", "%.*f"}) {
        if (fmt[3] == 'f' && std::abs(v) > 1e30) continue;
        std::snprintf(buf, sizeof buf, fmt, p, v);
        check_parse<float>(buf);
        check_parse<double>(buf);
      }
    }
  }
}

TEST_CASE("numbers: the portable formatter writes std::to_chars's text, which reads back", "[cli][numbers]") {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 50000; ++i) {
    const auto bits = rng();
    check_format(std::bit_cast<double>(bits));
    check_format(std::bit_cast<float>(std::uint32_t(bits)));
  }
  for (int e = -149; e <= 127; ++e) check_format(std::ldexp(1.0f, e));  // powers of two: uneven rounding gaps
  for (int e = -1074; e <= 1023; ++e) check_format(std::ldexp(1.0, e));
  for (const float v : {0.0f, -0.0f, 1.0f, 0.1f, 1e-4f, 1e-5f, 123456.0f, 1e7f, 1.5e9f, 16777216.0f, 1e10f,
                        std::numeric_limits<float>::max(), std::numeric_limits<float>::denorm_min(),
                        std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()}) {
    check_format(v);
    check_format(double(v));
  }
  for (std::uint32_t k = 1; k < 100000; k += 37) {  // integers and simple decimals, where fixed wins ties
    check_format(float(k));
    check_format(double(k) / 100);
  }
}
