// See reader.hpp.
#include "core/files/formats/reader.hpp"

namespace mlsdeform::files::formats {

std::string shown(std::string_view token) {
  std::string s = "'";
  for (std::size_t i = 0; i < token.size(); ++i) {
    if (i == 40) {
      s += "...";
      break;
    }
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f) {
      s += char(c);
    } else {
      static const char hex[] = "0123456789abcdef";
      s += "\\x";
      s += hex[c >> 4];
      s += hex[c & 15];
    }
  }
  return s + "'";
}

std::string shortest_text(double v) {
  char buf[32];
  return std::string(buf, real_to_chars(buf, buf + sizeof buf, v));
}

std::string non_finite(std::size_t vertex) {
  return "vertex " + std::to_string(vertex) + " has a non-finite coordinate";
}

void check_count(std::uint64_t count, std::size_t min_bytes, std::size_t remaining, const std::string& what,
                 const std::string& path, const std::string& where, bool text) {
  // A text body's last line may end without a newline: one byte less than count * min_bytes.
  const std::size_t final_newline = text && count > 0 ? 1 : 0;
  if (count > std::numeric_limits<std::uint32_t>::max() || count * min_bytes > remaining + final_newline)
    throw InputError(path,
                     "the header promises " + std::to_string(count) + " " + what + ", but only " +
                         std::to_string(remaining) + " bytes follow (at least " + std::to_string(min_bytes) +
                         " per item)",
                     where);
}

std::string out_of_range(std::size_t face, std::int64_t v, std::uint64_t nv) {
  return "face " + std::to_string(face) + " refers to vertex " + std::to_string(v) + ", but there are only " +
         std::to_string(nv) + " vertices (0 to " + std::to_string(std::int64_t(nv) - 1) + ")";
}

}  // namespace mlsdeform::files::formats
