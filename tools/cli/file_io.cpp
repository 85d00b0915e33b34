#include "tools/cli/file_io.hpp"

#include "tools/cli/error.hpp"

#include <zlib.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

namespace mlsdeform::cli {
namespace {

std::string errno_text(int e) { return std::strerror(e); }

std::string parent_dir(const std::string& path) {
  const std::filesystem::path p(path);
  const auto parent = p.parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

// The temporary file being written, removed by the signal handler if the user interrupts us. A fixed buffer:
// the handler may only call async-signal-safe functions (unlink, signal, raise).
char g_temp_path[4096];
std::atomic<bool> g_handler_installed{false};
// While a run defers interrupts (defer_interrupts), the first signal is only recorded here; the run polls it
// between its outputs and removes what it wrote. A second signal, or one outside a deferring run, removes the
// temporary file and ends the process at once.
volatile std::sig_atomic_t g_deferring = 0;
volatile std::sig_atomic_t g_pending = 0;

extern "C" void on_interrupt(int sig) {
  if (g_deferring && g_pending == 0) {
    g_pending = sig;
    return;
  }
  if (g_temp_path[0] != '\0') ::unlink(g_temp_path);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

void install_handler_once() {
  if (g_handler_installed.exchange(true)) return;
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  std::signal(SIGHUP, on_interrupt);
}

}  // namespace

std::string replaced_path(const std::string& path) {
  // Each link's target, relative to the link's folder; 40 links at most, as the kernel allows (ELOOP).
  std::filesystem::path p(path);
  for (int links = 0; links < 40; ++links) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p.string();
    std::error_code ec;
    const std::filesystem::path target = std::filesystem::read_symlink(p, ec);
    if (ec) throw InputError(path, "cannot read the symbolic link: " + ec.message());
    p = target.is_absolute() ? target : p.parent_path() / target;
  }
  throw InputError(path, "cannot write: too many levels of symbolic links");
}

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

std::string input_limit(std::size_t max_bytes) {
  return "the input limit of " + std::to_string(max_bytes >> 20) + " MiB (--max-input-mib raises it)";
}

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

/// For inputs that are not regular files (a pipe, /dev/stdin): read whole, within the limit, to know the size.
class OwnedMemorySource final : public ByteSource {
 public:
  explicit OwnedMemorySource(std::string data) : data_(std::move(data)), view_(data_) {}
  std::size_t size() const override { return view_.size(); }
  std::size_t read(char* dst, std::size_t n) override { return view_.read(dst, n); }
  void rewind() override { view_.rewind(); }

 private:
  std::string data_;
  MemorySource view_;
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

std::unique_ptr<ByteSource> memory_source(std::string_view data) { return std::make_unique<MemorySource>(data); }

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

std::string gzip(std::string_view data) {
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)  // 16: gzip header
    throw std::runtime_error("zlib: deflateInit2 failed");
  std::string out;
  const auto* next = reinterpret_cast<const Bytef*>(data.data());
  std::size_t left = data.size();
  char buf[1 << 16];
  int ret = Z_OK;
  do {
    if (zs.avail_in == 0 && left > 0) {
      const auto chunk = std::min<std::size_t>(left, 1u << 30);
      zs.next_in = const_cast<Bytef*>(next);
      zs.avail_in = uInt(chunk);
      next += chunk;
      left -= chunk;
    }
    zs.next_out = reinterpret_cast<Bytef*>(buf);
    zs.avail_out = sizeof buf;
    ret = deflate(&zs, left == 0 ? Z_FINISH : Z_NO_FLUSH);
    out.append(buf, sizeof buf - zs.avail_out);
  } while (ret != Z_STREAM_END);
  deflateEnd(&zs);
  return out;
}

void check_output_path(const std::string& path, bool force) {
  if (path.empty()) throw InputError(path, "empty output file name");
  struct stat st {};
  const std::string file = force ? replaced_path(path) : path;
  if (::stat(file.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) throw InputError(path, "cannot write: is a directory");
  if (!force && ::lstat(path.c_str(), &st) == 0) throw InputError(path, "already exists (use --force to overwrite)");
  const std::string dir = parent_dir(file);
  if (::stat(dir.c_str(), &st) != 0)
    throw InputError(path, "cannot write: directory '" + dir + "': " + errno_text(errno));
  if (!S_ISDIR(st.st_mode)) throw InputError(path, "cannot write: '" + dir + "' is not a directory");
  if (::access(dir.c_str(), W_OK) != 0)
    throw InputError(path, "cannot write: directory '" + dir + "': " + errno_text(errno));
}

void write_file_atomic(const std::string& path, std::string_view bytes, bool force) {
  install_handler_once();
  static std::atomic<unsigned> counter{0};
  // With force, a symbolic link stays a link: the file it points to is replaced (in that file's folder, so
  // that the rename stays on one file system), and keeps its permission bits.
  const std::string file = force ? replaced_path(path) : path;
  struct stat existing {};
  const bool replacing = force && ::stat(file.c_str(), &existing) == 0 && S_ISREG(existing.st_mode);
  const std::filesystem::path p(file);
  std::string name = ".";
  name += p.filename().string();
  name += ".tmp-";
  name += std::to_string(::getpid());
  name += "-";
  name += std::to_string(counter++);
  const std::string temp = (p.parent_path() / name).string();
  if (temp.size() >= sizeof g_temp_path) throw InputError(path, "cannot write: path too long");

  std::memcpy(g_temp_path, temp.c_str(), temp.size() + 1);
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) {
    const int e = errno;
    g_temp_path[0] = '\0';
    throw InputError(path, "cannot write: " + errno_text(e));
  }
  auto fail = [&](int e) {
    ::close(fd);
    ::unlink(temp.c_str());
    g_temp_path[0] = '\0';
    throw InputError(path, "cannot write: " + errno_text(e));
  };
  if (replacing && ::fchmod(fd, existing.st_mode & 0777) != 0) fail(errno);
  const char* data = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail(errno);
    }
    data += n;
    left -= std::size_t(n);
  }
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(temp.c_str());
    g_temp_path[0] = '\0';
    throw InputError(path, "cannot write: " + errno_text(e));
  }

  int rc;
  if (force) {
    rc = ::rename(temp.c_str(), file.c_str());
  } else {
    // No clobbering even if `path` appeared since check_output_path (another process, or a duplicate name).
    rc = ::renameat2(AT_FDCWD, temp.c_str(), AT_FDCWD, path.c_str(), RENAME_NOREPLACE);
    if (rc != 0 && (errno == EINVAL || errno == ENOSYS)) {  // a file system without RENAME_NOREPLACE
      struct stat st {};
      if (::stat(path.c_str(), &st) == 0) {
        rc = -1;
        errno = EEXIST;
      } else {
        rc = ::rename(temp.c_str(), path.c_str());
      }
    }
  }
  if (rc != 0) {
    const int e = errno;
    ::unlink(temp.c_str());
    g_temp_path[0] = '\0';
    if (e == EEXIST) throw InputError(path, "already exists (use --force to overwrite)");
    throw InputError(path, "cannot write: " + errno_text(e));
  }
  g_temp_path[0] = '\0';
}

}  // namespace mlsdeform::cli

namespace mlsdeform::cli {

void defer_interrupts(bool on) {
  install_handler_once();
  g_deferring = on ? 1 : 0;
}

int pending_interrupt() { return g_pending; }

}  // namespace mlsdeform::cli
