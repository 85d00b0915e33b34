// mlsdeform files: the one error type the user sees.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace mlsdeform::files {

/// A problem with the user's input or output (a missing file, a malformed mesh or handles file, an
/// unwritable output...). main() prints it as one line, "mlsdeform: error: FILE: PROBLEM", and exits with 2.
/// `where` is the JSON path or "line N" when known, and empty otherwise.
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, const std::string& problem, const std::string& where = {})
      : std::runtime_error(format(file, problem, where)), file_(file), problem_(problem), where_(where) {}

  const std::string& file() const { return file_; }
  const std::string& problem() const { return problem_; }
  const std::string& where() const { return where_; }

 private:
  static std::string format(const std::string& file, const std::string& problem, const std::string& where) {
    std::string s = file.empty() ? std::string() : file + ": ";
    if (!where.empty()) s += where + ": ";
    return one_line(s + problem);
  }
  /// Control characters (a newline in a file name, a byte of a binary file read as text) and bytes that are not
  /// UTF-8 as \xNN: the message stays one line of valid UTF-8 (a terminal shows it, Python's str holds it), and
  /// a file name in UTF-8 stays as it is.
  static std::string one_line(const std::string& m) {
    std::string out;
    for (std::size_t i = 0; i < m.size();) {
      const auto c = static_cast<unsigned char>(m[i]);
      if (c >= 0x20 && c < 0x7f) {
        out += m[i++];
        continue;
      }
      if (const std::size_t n = utf8_length(m, i)) {
        out.append(m, i, n);
        i += n;
        continue;
      }
      static const char hex[] = "0123456789abcdef";
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
      ++i;
    }
    return out;
  }
  /// The length of the well-formed UTF-8 sequence of 2 to 4 bytes at m[i] (no overlong form, no surrogate, at
  /// most U+10FFFF: Unicode's table 3-7), or 0.
  static std::size_t utf8_length(const std::string& m, std::size_t i) {
    const auto at = [&](std::size_t k) { return i + k < m.size() ? static_cast<unsigned char>(m[i + k]) : 0u; };
    const unsigned c = at(0);
    const auto cont = [&](std::size_t k, unsigned lo = 0x80, unsigned hi = 0xbf) { return at(k) >= lo && at(k) <= hi; };
    if (c >= 0xc2 && c <= 0xdf) return cont(1) ? 2 : 0;
    if (c == 0xe0) return cont(1, 0xa0) && cont(2) ? 3 : 0;
    if ((c >= 0xe1 && c <= 0xec) || c == 0xee || c == 0xef) return cont(1) && cont(2) ? 3 : 0;
    if (c == 0xed) return cont(1, 0x80, 0x9f) && cont(2) ? 3 : 0;
    if (c == 0xf0) return cont(1, 0x90) && cont(2) && cont(3) ? 4 : 0;
    if (c >= 0xf1 && c <= 0xf3) return cont(1) && cont(2) && cont(3) ? 4 : 0;
    if (c == 0xf4) return cont(1, 0x80, 0x8f) && cont(2) && cont(3) ? 4 : 0;
    return 0;
  }
  std::string file_, problem_, where_;
};

}  // namespace mlsdeform::files
