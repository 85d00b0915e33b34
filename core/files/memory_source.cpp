// mlsdeform files: the parts of file_io.hpp that need no file system or zlib (file names, bytes in memory), so
// that the web page's module, which has neither, reads meshes through the same readers.
#include "core/files/file_io.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>

namespace mlsdeform::files {

bool is_gzip_path(std::string_view path) {
  if (path.size() < 3) return false;
  std::string tail(path.substr(path.size() - 3));
  std::transform(tail.begin(), tail.end(), tail.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return tail == ".gz";
}

std::string format_extension(std::string_view path) {
  if (is_gzip_path(path)) path.remove_suffix(3);
  const auto slash = path.find_last_of('/');
  const auto name = slash == std::string_view::npos ? path : path.substr(slash + 1);
  const auto dot = name.find_last_of('.');
  if (dot == std::string_view::npos || dot == 0) return {};
  std::string ext(name.substr(dot + 1));
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

namespace {

class MemorySource final : public ByteSource {
 public:
  explicit MemorySource(std::string_view data) : data_(data) {}
  std::size_t size() const override { return data_.size(); }
  std::size_t read(char* dst, std::size_t n) override {
    n = std::min(n, data_.size() - pos_);
    if (n > 0) std::memcpy(dst, data_.data() + pos_, n);  // an empty view's data() may be null
    pos_ += n;
    return n;
  }
  void rewind() override { pos_ = 0; }

 private:
  std::string_view data_;
  std::size_t pos_ = 0;
};

}  // namespace

std::unique_ptr<ByteSource> memory_source(std::string_view data) { return std::make_unique<MemorySource>(data); }

}  // namespace mlsdeform::files
