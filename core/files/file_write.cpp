// mlsdeform files: all-or-nothing writes (file_io.hpp): checked output paths, a temporary file renamed over the
// output, removed again when the user interrupts, and gzip compression.
#include <mlsdeform/files_error.hpp>
#include "core/files/file_io.hpp"

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
#include <stdexcept>

namespace mlsdeform::files {
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

void defer_interrupts(bool on) {
  install_handler_once();
  g_deferring = on ? 1 : 0;
}

int pending_interrupt() { return g_pending; }

}  // namespace mlsdeform::files
