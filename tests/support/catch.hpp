#pragma once
// Catch2 for the tests, version 2 (Debian 12: one header, catch2/catch.hpp) or 3 (Debian 13: a header per
// part). The tests use Catch2 3's names; with Catch2 2 this header supplies the few that it spells otherwise,
// so a test file includes this header alone and compiles against either:
//   Catch::Matchers::ContainsSubstring  (v2: Catch::Matchers::Contains, which v3 keeps for ranges)
//   Catch::Approx                       (v2: Catch::Detail::Approx)
//   Catch::getSeed()                    (v2: Catch::getSeed(); 0 there unless --rng-seed is given, v3 always
//                                        has a seed, random unless --rng-seed is given)
// Catch::Matchers::StartsWith, GENERATE, TEMPLATE_TEST_CASE and Catch::Detail::stringify are the same in both.
// No CMake definition chooses: the installed headers tell (the WebAssembly build compiles Catch2 2's header).
#if __has_include(<catch2/catch_test_macros.hpp>)
#include <catch2/catch_approx.hpp>
#include <catch2/catch_get_random_seed.hpp>
#include <catch2/catch_session.hpp>
#include <catch2/catch_template_test_macros.hpp>
#include <catch2/catch_test_macros.hpp>
#include <catch2/generators/catch_generators.hpp>
#include <catch2/matchers/catch_matchers_string.hpp>
#else
#include <catch2/catch.hpp>

#include <cstdint>
#include <string>

namespace Catch {
using Detail::Approx;
inline std::uint32_t getSeed() { return rngSeed(); }
namespace Matchers {
inline StdString::ContainsMatcher ContainsSubstring(const std::string& str,
                                                    CaseSensitive::Choice cs = CaseSensitive::Yes) {
  return Contains(str, cs);
}
}  // namespace Matchers
}  // namespace Catch
#endif
