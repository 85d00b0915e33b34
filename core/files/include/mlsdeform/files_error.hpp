// mlsdeform files: the one error type the user sees.
#pragma once

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
  /// Control characters (a newline in a file name, a byte of a binary file read as text) as \xNN: the
  /// message stays one line.
  static std::string one_line(const std::string& m) {
    std::string out;
    for (const char ch : m) {
      const auto c = static_cast<unsigned char>(ch);
      if (c >= 0x20 && c != 0x7f) {
        out += ch;
        continue;
      }
      static const char hex[] = "0123456789abcdef";
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    }
    return out;
  }
  std::string file_, problem_, where_;
};

}  // namespace mlsdeform::files
