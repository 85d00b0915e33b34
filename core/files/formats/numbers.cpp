// See numbers.hpp: the portable twins of the floating-point std::from_chars / std::to_chars.
#include "core/files/formats/numbers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>

namespace mlsdeform::files::formats {
namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

char lower(char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; }

// Whether [p, last) starts with the lower-case `word`, in any case.
bool starts_with_word(const char* p, const char* last, const char* word) {
  for (; *word != '\0'; ++p, ++word)
    if (p == last || lower(*p) != *word) return false;
  return true;
}

// The C library's conversion for R; both are correctly rounded (glibc, musl).
float convert(const char* s, float) { return std::strtof(s, nullptr); }
double convert(const char* s, double) { return std::strtod(s, nullptr); }

template <class R>
RealParse parse(const char* first, const char* last, R& out) {
  const char* p = first;
  if (p != last && *p == '-') ++p;
  bool nonzero = false;  // a non-zero digit in the mantissa: a zero result is then an underflow
  bool special = false;
  if (starts_with_word(p, last, "inf")) {
    p += starts_with_word(p, last, "infinity") ? 8 : 3;
    special = true;
  } else if (starts_with_word(p, last, "nan")) {
    p += 3;
    if (p != last && *p == '(') {  // nan(n-char-sequence): letters, digits and '_', then ')'
      const char* q = p + 1;
      while (q != last && (is_digit(*q) || (lower(*q) >= 'a' && lower(*q) <= 'z') || *q == '_')) ++q;
      if (q != last && *q == ')') p = q + 1;
    }
    special = true;
  } else {
    std::size_t digits = 0;
    for (; p != last && is_digit(*p); ++p, ++digits) nonzero |= *p != '0';
    if (p != last && *p == '.')
      for (++p; p != last && is_digit(*p); ++p, ++digits) nonzero |= *p != '0';
    if (digits == 0) return {first, std::errc::invalid_argument};
    if (p != last && (*p == 'e' || *p == 'E')) {  // an exponent only when digits follow: "1e" reads as 1
      const char* q = p + 1;
      if (q != last && (*q == '+' || *q == '-')) ++q;
      if (q != last && is_digit(*q)) {
        while (q != last && is_digit(*q)) ++q;
        p = q;
      }
    }
  }
  // The checked prefix, NUL-terminated, for strtod: it reads exactly the grammar above (no hex can occur).
  char small[64];
  std::string large;
  const std::size_t n = std::size_t(p - first);
  const char* text = small;
  if (n < sizeof small) {
    std::memcpy(small, first, n);
    small[n] = '\0';
  } else {
    large.assign(first, n);
    text = large.c_str();
  }
  const R v = convert(text, R());
  if (!special && (std::isinf(v) || (v == 0 && nonzero))) return {p, std::errc::result_out_of_range};
  out = v;
  return {p, std::errc()};
}

// Appends `s` to [*at, last); false if it does not fit.
bool put(char*& at, char* last, const char* s, std::size_t n) {
  if (std::size_t(last - at) < n) return false;
  std::memcpy(at, s, n);
  at += n;
  return true;
}

// The decimal text [-]d.ddde(+|-)xx with its last digit one up (carried); false where the carry would reach
// past the first digit (that value has fewer digits and was tried before).
bool next_up(char* sci) {
  char* last = std::strchr(sci, 'e') - 1;
  for (char* c = last; c >= sci; --c) {
    if (*c == '.') continue;
    if (!is_digit(*c)) return false;
    if (*c != '9') {
      ++*c;
      return true;
    }
    *c = '0';
  }
  return false;
}

template <class R>
char* format(char* first, char* last, R v) {
  char* at = first;
  if (std::isnan(v)) return put(at, last, std::signbit(v) ? "-nan" : "nan", std::signbit(v) ? 4 : 3) ? at : nullptr;
  if (std::isinf(v)) return put(at, last, v < 0 ? "-inf" : "inf", v < 0 ? 4 : 3) ? at : nullptr;
  if (v == 0) return put(at, last, std::signbit(v) ? "-0" : "0", std::signbit(v) ? 2 : 1) ? at : nullptr;
  // The fewest significant digits whose correctly rounded text reads back to v.
  char sci[48];
  for (int p = 1; p <= std::numeric_limits<R>::max_digits10; ++p) {
    std::snprintf(sci, sizeof sci, "%.*e", p - 1, double(v));
    const R back = convert(sci, R());
    if (back == v) break;
    // At a power of two the values below v are twice as close: the nearest p digits can fall below and out of
    // v's rounding interval while the next p digits up are inside it (Ryu, and so to_chars, finds those).
    if (std::abs(back) < std::abs(v) && next_up(sci) && convert(sci, R()) == v) break;
  }
  // sci is [-]d[.ddd]e(+|-)xx: its digits and decimal exponent (v = d.ddd * 10^exponent).
  const char* s = sci;
  const bool negative = *s == '-';
  if (negative) ++s;
  char digits[24] = {};
  int n = 0;
  for (; *s != 'e'; ++s)
    if (is_digit(*s)) digits[n++] = *s;
  const int exponent = std::atoi(s + 1);
  // Scientific as to_chars writes it: d[.ddd]e(+|-)xx, at least two exponent digits.
  char scientific[48];
  int ns = 0;
  scientific[ns++] = digits[0];
  if (n > 1) {
    scientific[ns++] = '.';
    for (int i = 1; i < n; ++i) scientific[ns++] = digits[i];
  }
  ns += std::snprintf(scientific + ns, sizeof scientific - std::size_t(ns), "e%c%02d", exponent < 0 ? '-' : '+',
                      exponent < 0 ? -exponent : exponent);
  // Fixed: the digits with the point moved, padded with zeros. Its length is known before it is written; only
  // a shorter (or equal) one is written.
  const int nf = exponent >= 0 ? std::max(n, exponent + 1) + (n > exponent + 1 ? 1 : 0) : 1 + 1 + (-exponent - 1) + n;
  if (negative && !put(at, last, "-", 1)) return nullptr;
  if (nf > ns) return put(at, last, scientific, std::size_t(ns)) ? at : nullptr;
  char fixed[400];
  int k = 0;
  if (exponent >= n - 1) {
    // An integer: to_chars writes its exact value (as many digits as the shortest ones padded with zeros).
    k = std::snprintf(fixed, sizeof fixed, "%.0f", std::abs(double(v)));
  } else if (exponent >= 0) {
    for (int i = 0; i < std::max(n, exponent + 1); ++i) {
      if (i == exponent + 1) fixed[k++] = '.';
      fixed[k++] = i < n ? digits[i] : '0';
    }
  } else {
    fixed[k++] = '0';
    fixed[k++] = '.';
    for (int i = 0; i < -exponent - 1; ++i) fixed[k++] = '0';
    for (int i = 0; i < n; ++i) fixed[k++] = digits[i];
  }
  return put(at, last, fixed, std::size_t(k)) ? at : nullptr;
}

}  // namespace

RealParse portable_from_chars(const char* first, const char* last, float& out) { return parse(first, last, out); }
RealParse portable_from_chars(const char* first, const char* last, double& out) { return parse(first, last, out); }

char* portable_to_chars(char* first, char* last, float v) { return format(first, last, v); }
char* portable_to_chars(char* first, char* last, double v) { return format(first, last, v); }

}  // namespace mlsdeform::files::formats
