// mlsdeform CLI: per-frame reporting. On a terminal, a progress bar redrawn in place on stderr; otherwise
// (a pipe, a log, a test) one line per frame on stdout.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <string>

namespace mlsdeform::cli {

class Progress {
 public:
  Progress(std::size_t total, bool quiet) : total_(total), quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1) {}

  void frame(std::size_t index, double deform_ms, double write_ms, const std::string& path) {
    if (quiet_) return;
    if (tty_) {
      constexpr int width = 30;
      const int filled = int(double(index + 1) / double(total_) * width);
      std::fprintf(stderr, "\r[%s%s] %zu/%zu  deform %.2f ms  write %.1f ms  %s\x1b[K",
                   std::string(std::size_t(filled), '#').c_str(), std::string(std::size_t(width - filled), '.').c_str(),
                   index + 1, total_, deform_ms, write_ms, path.c_str());
      if (index + 1 == total_) std::fputc('\n', stderr);
      std::fflush(stderr);
    } else {
      std::printf("frame %zu/%zu: deform %.3f ms, write %.1f ms -> %s\n", index + 1, total_, deform_ms, write_ms,
                  path.c_str());
      std::fflush(stdout);  // a line per frame as it is written, also through a pipe
    }
  }
  /// Ends a bar cut short by an error, so the error message starts on its own line.
  void abort() {
    if (!quiet_ && tty_) std::fputc('\n', stderr);
  }

 private:
  std::size_t total_;
  bool quiet_, tty_;
};

}  // namespace mlsdeform::cli
