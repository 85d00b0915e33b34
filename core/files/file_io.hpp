// mlsdeform files: bounded, streamed reads (gzip decompressed on the fly), and all-or-nothing writes.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

namespace mlsdeform::files {

/// The whole file. Throws InputError naming `path` if it is missing, unreadable, a directory or larger than
/// `max_bytes`.
std::string read_file(const std::string& path, std::size_t max_bytes = std::size_t(4) << 30);

/// Whether `path` ends in ".gz" (any case).
bool is_gzip_path(std::string_view path);
/// The lower-case extension without the dot, looking through a trailing ".gz": "a/b.PLY.gz" -> "ply".
std::string format_extension(std::string_view path);

/// Bytes read in order, a chunk at a time, with their total known before the first read (so that a reader can
/// check the counts a header promises against what follows, before allocating for them).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  /// The total number of bytes this source yields.
  virtual std::size_t size() const = 0;
  /// Copies the next bytes into `dst`, at most `n`; fewer than `n` only at the end. Throws InputError on a
  /// read error or corrupt data.
  virtual std::size_t read(char* dst, std::size_t n) = 0;
  /// Back to the first byte.
  virtual void rewind() = 0;
};

/// A file's bytes, streamed; decompressed on the fly when `path` ends in ".gz". Throws InputError naming
/// `path` if it is missing, unreadable or a directory, or if the file (or its decompressed data) is larger
/// than `max_bytes`. A .gz file is decompressed twice, first to measure and check it (corrupt, truncated or
/// too large data is refused then, with nothing allocated for its contents), then as it is read: memory stays
/// at a few buffers whatever the sizes.
std::unique_ptr<ByteSource> open_input(const std::string& path, std::size_t max_bytes);
/// The bytes of `data` (which must outlive the source), as they are.
std::unique_ptr<ByteSource> memory_source(std::string_view data);
/// The decompressed bytes of the gzip data (all members) that `compressed` yields, checked as open_input
/// checks a .gz file; `path` names it in errors.
std::unique_ptr<ByteSource> gunzip_source(std::unique_ptr<ByteSource> compressed, const std::string& path,
                                          std::size_t max_bytes);

/// Decompresses gzip data (all members); `path` names the file in errors (corrupt or truncated data, or more
/// than `max_bytes` decompressed: refused as soon as the output passes the limit, before it is all in memory).
std::string gunzip(std::string_view compressed, const std::string& path, std::size_t max_bytes = std::size_t(4) << 30);
/// Compresses to the gzip format (level 6).
std::string gzip(std::string_view data);

/// Throws InputError naming `path` when it cannot be an output: it exists (even as a dangling symbolic link)
/// and `force` is false, it is a directory, or its directory does not exist. Called before any work, so that
/// a bad output path fails fast.
void check_output_path(const std::string& path, bool force);

/// The file that writing `path` with `force` replaces: `path`, or, if it is a symbolic link, the file at the
/// end of its chain of links (which need not exist). Throws InputError for a link that cannot be read or a
/// loop.
std::string replaced_path(const std::string& path);

/// Writes `bytes` to `path` all or nothing: into a temporary file in the same directory, then renamed over
/// `path` (without `force`, an existing `path` is left alone and reported). With `force`, an existing file
/// keeps its permission bits (not its owner or its other hard links: the file is a new one), and a symbolic
/// link stays in place: the file it points to is replaced (replaced_path). On any failure the temporary file
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

}  // namespace mlsdeform::files
