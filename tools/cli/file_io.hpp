// mlsdeform CLI: whole-file reads, gzip in memory, and all-or-nothing writes.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace mlsdeform::cli {

/// The whole file. Throws InputError naming `path` if it is missing, unreadable, a directory or larger than
/// `max_bytes`.
std::string read_file(const std::string& path, std::size_t max_bytes = std::size_t(4) << 30);

/// Whether `path` ends in ".gz" (any case).
bool is_gzip_path(std::string_view path);
/// The lower-case extension without the dot, looking through a trailing ".gz": "a/b.PLY.gz" -> "ply".
std::string format_extension(std::string_view path);

/// Decompresses gzip data (all members); `path` names the file in errors (corrupt or truncated data).
std::string gunzip(std::string_view compressed, const std::string& path);
/// Compresses to the gzip format (level 6).
std::string gzip(std::string_view data);

/// Throws InputError naming `path` when it cannot be an output: it exists and `force` is false, it is a
/// directory, or its directory does not exist. Called before any work, so that a bad output path fails fast.
void check_output_path(const std::string& path, bool force);

/// Writes `bytes` to `path` all or nothing: into a temporary file in the same directory, then renamed over
/// `path` (without `force`, an existing `path` is left alone and reported). On any failure the temporary file
/// is removed and InputError names `path` and the system's reason. An interrupt (SIGINT, SIGTERM) while
/// writing removes the temporary file too.
void write_file_atomic(const std::string& path, std::string_view bytes, bool force);

/// All or nothing across several outputs: while on, the first SIGINT, SIGTERM or SIGHUP is only recorded
/// (pending_interrupt() returns its number) so that the caller can remove the outputs it wrote before exiting;
/// a second signal ends the process at once (removing a temporary file being written, not the earlier outputs).
void defer_interrupts(bool on);
int pending_interrupt();

/// Thrown by a run that stopped for a signal, after removing what it wrote: exit status 128 + signal.
struct Interrupted {
  int signal;
  std::size_t removed;
};

}  // namespace mlsdeform::cli
