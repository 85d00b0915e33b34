// mlsdeform files: bounded, streamed reads (file_io.hpp): whole files, and byte sources over a file, memory or
// gzip data decompressed on the fly, each refusing more than its limit before allocating for it.
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"

#include <zlib.h>

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <vector>

namespace mlsdeform::files {
namespace {

std::string errno_text(int e) { return std::strerror(e); }

}  // namespace

std::string read_file(const std::string& path, std::size_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw InputError(path, "cannot open: " + errno_text(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(path, "cannot read: is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "cannot open: " + errno_text(errno));
  if (S_ISREG(st.st_mode) && std::size_t(st.st_size) > max_bytes)
    throw InputError(
        path, "file too large (" + std::to_string(st.st_size) + " bytes, limit " + std::to_string(max_bytes) + ")");
  std::string data;
  if (S_ISREG(st.st_mode)) data.reserve(std::size_t(st.st_size));
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    data.append(buf, std::size_t(in.gcount()));
    if (data.size() > max_bytes) throw InputError(path, "file too large");
  }
  if (in.bad()) throw InputError(path, "read error: " + errno_text(errno));
  return data;
}

namespace {

std::string input_limit(std::size_t max_bytes) {
  return "the input limit of " + std::to_string(max_bytes >> 20) + " MiB (--max-input-mib raises it)";
}

/// For inputs that are not regular files (a pipe, /dev/stdin): read whole, within the limit, to know the size.
class OwnedMemorySource final : public ByteSource {
 public:
  explicit OwnedMemorySource(std::string data) : data_(std::move(data)), view_(memory_source(data_)) {}
  std::size_t size() const override { return view_->size(); }
  std::size_t read(char* dst, std::size_t n) override { return view_->read(dst, n); }
  void rewind() override { view_->rewind(); }

 private:
  std::string data_;
  std::unique_ptr<ByteSource> view_;
};

class FileSource final : public ByteSource {
 public:
  FileSource(std::FILE* f, std::size_t size, std::string path) : f_(f), size_(size), path_(std::move(path)) {}
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;
  ~FileSource() override { std::fclose(f_); }
  std::size_t size() const override { return size_; }
  std::size_t read(char* dst, std::size_t n) override {
    // Never past the size measured at open (a file that grows meanwhile is read as it was).
    n = std::min(n, size_ - pos_);
    const std::size_t got = std::fread(dst, 1, n, f_);
    if (got < n) {
      if (std::ferror(f_)) throw InputError(path_, "read error: " + errno_text(errno));
      throw InputError(path_, "the file shrank while it was read");
    }
    pos_ += got;
    return got;
  }
  void rewind() override {
    if (std::fseek(f_, 0, SEEK_SET) != 0) throw InputError(path_, "cannot seek: " + errno_text(errno));
    pos_ = 0;
  }

 private:
  std::FILE* f_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string path_;
};

class GzipSource final : public ByteSource {
 public:
  GzipSource(std::unique_ptr<ByteSource> in, std::string path, std::size_t max_bytes)
      : in_(std::move(in)), path_(std::move(path)), inbuf_(std::size_t(1) << 16) {
    // The first pass: measure, and refuse corrupt, truncated or too large data before anything is built on it.
    std::vector<char> scratch(std::size_t(1) << 16);
    for (std::size_t n; (n = read(scratch.data(), scratch.size())) > 0;) {
      size_ += n;
      if (size_ > max_bytes) throw InputError(path_, "decompresses to more than " + input_limit(max_bytes));
    }
    rewind();
  }
  GzipSource(const GzipSource&) = delete;
  GzipSource& operator=(const GzipSource&) = delete;
  std::size_t size() const override { return size_; }
  std::size_t read(char* dst, std::size_t n) override {
    std::size_t produced = 0;
    while (produced < n && !done_) {
      if (zs_.avail_in == 0 && !in_eof_) refill();
      zs_.next_out = reinterpret_cast<Bytef*>(dst + produced);
      zs_.avail_out = uInt(std::min<std::size_t>(n - produced, std::size_t(1) << 30));
      const uInt before = zs_.avail_out;
      const int ret = inflate(&zs_, Z_NO_FLUSH);
      produced += before - zs_.avail_out;
      if (ret == Z_STREAM_END) {
        if (zs_.avail_in == 0 && !in_eof_) refill();
        if (zs_.avail_in == 0) {
          done_ = true;
        } else {
          inflateReset(&zs_);  // a further gzip member (as `cat a.gz b.gz` makes)
        }
        continue;
      }
      if (ret == Z_BUF_ERROR && zs_.avail_in == 0 && in_eof_) throw InputError(path_, "truncated gzip data");
      if (ret != Z_OK && ret != Z_BUF_ERROR)
        throw InputError(path_,
                         "corrupt gzip data (" + std::string(zs_.msg ? zs_.msg : "error " + std::to_string(ret)) + ")");
    }
    return produced;
  }
  void rewind() override {
    in_->rewind();
    inflateReset(&zs_);
    zs_.avail_in = 0;
    in_eof_ = done_ = false;
  }

 private:
  void refill() {
    const std::size_t k = in_->read(inbuf_.data(), inbuf_.size());
    in_eof_ = k < inbuf_.size();
    zs_.next_in = reinterpret_cast<Bytef*>(inbuf_.data());
    zs_.avail_in = uInt(k);
  }

  // The zlib stream, ended by its destructor also when the constructor throws.
  struct Inflater {
    z_stream zs{};
    Inflater() {
      if (inflateInit2(&zs, 15 + 32) != Z_OK)
        throw std::runtime_error("zlib: inflateInit2 failed");  // 32: gzip or zlib header
    }
    Inflater(const Inflater&) = delete;
    Inflater& operator=(const Inflater&) = delete;
    ~Inflater() { inflateEnd(&zs); }
  };

  std::unique_ptr<ByteSource> in_;
  std::string path_;
  std::vector<char> inbuf_;
  Inflater inflater_;
  z_stream& zs_ = inflater_.zs;
  bool in_eof_ = false, done_ = false;
  std::size_t size_ = 0;
};

}  // namespace

std::unique_ptr<ByteSource> gunzip_source(std::unique_ptr<ByteSource> compressed, const std::string& path,
                                          std::size_t max_bytes) {
  return std::make_unique<GzipSource>(std::move(compressed), path, max_bytes);
}

std::unique_ptr<ByteSource> open_input(const std::string& path, std::size_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw InputError(path, "cannot open: " + errno_text(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(path, "cannot read: is a directory");
  std::unique_ptr<ByteSource> raw;
  if (S_ISREG(st.st_mode)) {
    if (std::size_t(st.st_size) > max_bytes)
      throw InputError(path,
                       "file too large: " + std::to_string(st.st_size) + " bytes, more than " + input_limit(max_bytes));
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw InputError(path, "cannot open: " + errno_text(errno));
    raw = std::make_unique<FileSource>(f, std::size_t(st.st_size), path);
  } else {
    raw = std::make_unique<OwnedMemorySource>(read_file(path, max_bytes));
  }
  if (is_gzip_path(path)) return gunzip_source(std::move(raw), path, max_bytes);
  return raw;
}

std::string gunzip(std::string_view compressed, const std::string& path, std::size_t max_bytes) {
  const auto source = gunzip_source(memory_source(compressed), path, max_bytes);
  std::string out(source->size(), '\0');
  if (source->read(out.data(), out.size()) != out.size()) throw InputError(path, "gzip data changed between reads");
  return out;
}

}  // namespace mlsdeform::files
