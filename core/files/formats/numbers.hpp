// mlsdeform files: floating-point text for the mesh readers and writers, parsed and printed as
// std::from_chars / std::to_chars do (std::chars_format::general when parsing, the shortest round-trip text
// when printing). Where the standard library has them (__cpp_lib_to_chars) they are used as they are; where it
// does not (the libc++ of Debian's emscripten 3.1.6, for the web page's module) the portable twins below take
// their place: the same grammar checked by hand, converted by the C library's correctly rounded strtod / strtof,
// and the shortest "%.*e" text that reads back, laid out as to_chars lays it out. tests/cli/test_cli_numbers.cpp
// holds the twins against the standard library's, bitwise.
#pragma once

#include <charconv>
#include <system_error>

namespace mlsdeform::files::formats {

/// What a floating-point parse consumed (ptr) and how it ended, as std::from_chars_result.
struct RealParse {
  const char* ptr;
  std::errc ec;
};

/// std::from_chars(first, last, out) with std::chars_format::general: an optional '-' (no '+'), digits with an
/// optional '.', an optional exponent; "inf", "infinity", "nan", "nan(chars)" in any case. ptr: the end of the
/// longest such prefix. invalid_argument (ptr = first) when there is none; result_out_of_range (out unchanged)
/// when the value overflows to infinity or a non-zero value underflows to zero.
RealParse portable_from_chars(const char* first, const char* last, float& out);
RealParse portable_from_chars(const char* first, const char* last, double& out);

/// std::to_chars(first, last, v): the shortest decimal text that reads back to v, fixed or scientific, whichever
/// is shorter (fixed on a tie). Returns the end of the text, or nullptr if [first, last) is too small (32 bytes
/// always suffice).
char* portable_to_chars(char* first, char* last, float v);
char* portable_to_chars(char* first, char* last, double v);

/// The standard library's from_chars for R where it has one, else the portable twin.
template <class R>
RealParse real_from_chars(const char* first, const char* last, R& out) {
#if defined(__cpp_lib_to_chars) && __cpp_lib_to_chars >= 201611L
  const auto r = std::from_chars(first, last, out);
  return {r.ptr, r.ec};
#else
  return portable_from_chars(first, last, out);
#endif
}

/// The standard library's to_chars for R where it has one, else the portable twin; nullptr if too small.
template <class R>
char* real_to_chars(char* first, char* last, R v) {
#if defined(__cpp_lib_to_chars) && __cpp_lib_to_chars >= 201611L
  const auto r = std::to_chars(first, last, v);
  return r.ec == std::errc() ? r.ptr : nullptr;
#else
  return portable_to_chars(first, last, v);
#endif
}

}  // namespace mlsdeform::files::formats
