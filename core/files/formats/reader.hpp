// mlsdeform files: what the three mesh readers (obj_read.cpp, off_read.cpp, ply_read.cpp) share: the streamed
// input (Reader: lines or bytes through a buffer; Lines: the tokens of text lines), whole-token number parsing,
// the checks every format makes (finite coordinates, header counts against what follows, vertex indices) and
// the wording of their messages. mesh_read.cpp picks the reader by the file's extension.
//
// Memory: the input is streamed (a buffer of 1 MiB, longer only for a longer line), never held whole, and
// what is built grows in blocks (std::deque) where its final size is not known yet, then is copied once into
// the mesh's arrays: the peak is about twice the final arrays, whatever the input's size or format.
#pragma once

#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"
#include "core/files/formats/numbers.hpp"
#include "core/files/mesh.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <deque>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

namespace mlsdeform::files::formats {

// The UTF-8 byte-order mark, U+FEFF.
inline constexpr std::string_view kBom = "\xef\xbb\xbf";

inline std::string at_line(std::size_t line) { return "line " + std::to_string(line); }

/// A token from the file as a message shows it: quoted, bytes outside printable ASCII as \xNN (a binary file
/// read as text stays one readable line), at most 40 characters.
std::string shown(std::string_view token);

/// Whole-token number parsing: the token must be a number and nothing else (correctly rounded for floats).
/// std::errc::result_out_of_range: a whole number that T cannot hold (1e39 or 1e-46 as a float).
template <class T>
std::errc read_number(std::string_view token, T& out) {
  if (token.empty()) return std::errc::invalid_argument;
  const char* first = token.data();
  if (*first == '+') ++first;  // from_chars refuses a leading '+', which text formats use
  const char* const last = token.data() + token.size();
  if constexpr (std::is_floating_point_v<T>) {
    const RealParse r = real_from_chars(first, last, out);
    if (r.ptr != last) return std::errc::invalid_argument;
    return r.ec;
  } else {
    const auto r = std::from_chars(first, last, out);
    if (r.ptr != last) return std::errc::invalid_argument;
    return r.ec;
  }
}
template <class T>
bool parse_number(std::string_view token, T& out) {
  return read_number(token, out) == std::errc();
}

/// The shortest decimal text that reads back to `v`.
std::string shortest_text(double v);

/// A coordinate as T, or InputError: "not a number", or out of T's range (float: --precision double reads it).
template <class T>
T coordinate(std::string_view token, const std::string& path, const std::string& where) {
  T v = 0;
  const std::errc ec = read_number(token, v);
  if (ec == std::errc()) return v;
  if (ec == std::errc::result_out_of_range)
    throw InputError(path,
                     "number out of the range of " + std::string(std::is_same_v<T, float> ? "float" : "double") + ": " +
                         shown(token) + (std::is_same_v<T, float> ? " (--precision double reads it)" : ""),
                     where);
  throw InputError(path, "not a number: " + shown(token), where);
}

/// A ByteSource read through a buffer: whole lines (text formats) or bytes (binary PLY), counting what was
/// consumed so that header counts can be checked against what remains.
class Reader {
 public:
  static constexpr std::size_t kChunk = std::size_t(1) << 20;
  static constexpr std::size_t kMaxLine = std::size_t(64) << 20;

  // The buffer holds the whole input when it is small (no larger than need be: the fuzz targets read many).
  Reader(ByteSource& source, const std::string& path)
      : src_(source), path_(path), buf_(std::min(kChunk, source.size() + 1)) {}

  /// The next line without its '\n' (the last one also without); false at the end. Valid until the next call.
  bool line(std::string_view& out) {
    for (std::size_t scanned = begin_;;) {
      const void* nl = std::memchr(buf_.data() + scanned, '\n', end_ - scanned);
      if (nl != nullptr || (eof_ && begin_ < end_)) {
        const std::size_t stop = nl ? std::size_t(static_cast<const char*>(nl) - buf_.data()) : end_;
        out = std::string_view(buf_.data() + begin_, stop - begin_);
        const std::size_t next = nl ? stop + 1 : stop;
        consumed_ += next - begin_;
        begin_ = next;
        return true;
      }
      if (eof_) return false;
      scanned = end_ - begin_;  // offsets move to the front in fill()
      fill();
    }
  }
  /// The next `n` bytes; false if the input ends first.
  bool bytes(char* dst, std::size_t n) {
    while (n > 0) {
      if (begin_ == end_) {
        if (eof_) return false;
        fill();
        continue;
      }
      const std::size_t k = std::min(n, end_ - begin_);
      std::memcpy(dst, buf_.data() + begin_, k);
      begin_ += k, consumed_ += k, dst += k, n -= k;
    }
    return true;
  }
  /// Whether the input starts with `prefix`; if so, it is consumed. Only before anything else is read.
  bool skip_prefix(std::string_view prefix) {
    while (end_ - begin_ < prefix.size() && !eof_) fill();
    if (std::string_view(buf_.data() + begin_, end_ - begin_).substr(0, prefix.size()) != prefix) return false;
    begin_ += prefix.size();
    consumed_ += prefix.size();
    return true;
  }
  bool at_end() {
    if (begin_ == end_ && !eof_) fill();
    return begin_ == end_;
  }
  std::size_t remaining() const { return src_.size() - consumed_; }

 private:
  void fill() {
    if (begin_ > 0) {
      std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ == buf_.size()) {  // one line fills the buffer
      if (buf_.size() >= kMaxLine)
        throw InputError(path_, "a line longer than " + std::to_string(kMaxLine >> 20) + " MiB");
      buf_.resize(buf_.size() * 2);
    }
    const std::size_t want = buf_.size() - end_;
    const std::size_t got = src_.read(buf_.data() + end_, want);
    end_ += got;
    eof_ = got < want;
  }

  ByteSource& src_;
  const std::string& path_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0, consumed_ = 0;
  bool eof_ = false;
};

/// The blank-separated tokens of a line.
inline void split(std::string_view line, std::vector<std::string_view>& tokens) {
  constexpr const char* blanks = " \t\r\f\v";
  tokens.clear();
  std::size_t i = 0;
  while ((i = line.find_first_not_of(blanks, i)) != std::string_view::npos) {
    const std::size_t j = std::min(line.find_first_of(blanks, i), line.size());
    tokens.push_back(line.substr(i, j - i));
    i = j;
  }
}

/// Lines of a text, with their numbers; tokens split on blanks, a '#' starts a comment.
class Lines {
 public:
  explicit Lines(Reader& reader, std::size_t first_line = 1) : reader_(reader), line_(first_line - 1) {}
  /// The tokens of the next line (empty for a blank or comment line); false at the end of the text.
  bool next(std::vector<std::string_view>& tokens) {
    std::string_view l;
    if (!reader_.line(l)) return false;
    ++line_;
    raw_ = l;
    if (const auto hash = l.find('#'); hash != std::string_view::npos) l = l.substr(0, hash);
    split(l, tokens);
    return true;
  }
  /// The next line that has tokens; false at the end.
  bool next_content(std::vector<std::string_view>& tokens) {
    while (next(tokens))
      if (!tokens.empty()) return true;
    return false;
  }
  std::size_t line() const { return line_; }
  /// The last line as read (comment included), valid until the next call; tokens are views into it.
  std::string_view raw() const { return raw_; }

 private:
  Reader& reader_;
  std::size_t line_;
  std::string_view raw_;
};

/// The blocks' contents as one array; the blocks are freed.
template <class T>
std::vector<T> to_vector(std::deque<T>& blocks) {
  std::vector<T> v;
  v.reserve(blocks.size());
  v.assign(blocks.begin(), blocks.end());
  std::deque<T>().swap(blocks);  // free the blocks now
  return v;
}

template <class T>
bool finite3(const T* c) {
  return std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]);
}

/// What follows `last` (a token of `raw`) on the line, without trailing blanks or a line end's '\r'.
inline std::string_view tail_after(std::string_view raw, std::string_view last) {
  std::string_view tail = raw.substr(std::size_t(last.data() + last.size() - raw.data()));
  while (!tail.empty() && (tail.back() == '\r' || tail.back() == ' ' || tail.back() == '\t')) tail.remove_suffix(1);
  return tail;
}

/// The message for a vertex with an infinite or NaN coordinate.
std::string non_finite(std::size_t vertex);

/// Refuses a count that the rest of the file cannot hold (`min_bytes` per item), before allocating for it. In a
/// text body (`text`) each item's `min_bytes` count its line's newline, which the last line may lack.
void check_count(std::uint64_t count, std::size_t min_bytes, std::size_t remaining, const std::string& what,
                 const std::string& path, const std::string& where, bool text = false);

/// The message for a face corner that names no vertex (0 to nv - 1).
std::string out_of_range(std::size_t face, std::int64_t v, std::uint64_t nv);

// The readers, one file each; `path` names the input in errors.
template <class T>
BasicMesh<T> read_obj(Reader& reader, const std::string& path);
template <class T>
BasicMesh<T> read_off(Reader& reader, const std::string& path);
template <class T>
BasicMesh<T> read_ply(Reader& reader, const std::string& path);

}  // namespace mlsdeform::files::formats
