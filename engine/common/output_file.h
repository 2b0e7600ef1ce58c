// Writing an output file whole or not at all.
//
// Every file machplan writes (programs, reports, pictures, traces, recordings, logs, new
// stores) goes through AtomicOutput: the bytes go to a new temporary file beside the target
// ("DIR/.NAME.tmp-PID-N", in the same folder so that the final rename cannot cross file
// systems), commit() flushes it to the disk and renames it over the target. So:
//   * on any failure (a full disk, an I/O error, an exception while writing, the process
//     killed) the target is as it was: an old file byte for byte, or no file;
//   * no partial file is left behind: the destructor removes an uncommitted temporary (a
//     process killed outright may leave one, under its hidden name, never the target's);
//   * a failure throws OutputError (below) naming the target and the system's reason
//     (strerror), which the command line turns into exit 4.
// A new file gets the permissions a plain open() would give it (0666 less the umask); a file
// replaced keeps its own. A symbolic link to a file keeps pointing at it: the file it names is
// replaced. A target that is a device or a FIFO (/dev/stdout, a named pipe) has no content to
// keep: it is written straight through, and a write error still throws OutputError.
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>
#include <string_view>

namespace machplan {

// The system refused an output: a file (or standard output) could not be written (a full
// disk, no permission, an I/O error). Neither bad input (InputError, exit 2) nor a bug in
// machplan (exit 1): the command line exits 4. what() reads "FILE: cannot write: REASON",
// REASON the system's (strerror) when there is one.
class OutputError : public std::runtime_error {
 public:
  OutputError(std::string path, std::string reason)
      : std::runtime_error(path + ": cannot write: " + reason), path_(std::move(path)), reason_(std::move(reason)) {}
  const std::string& path() const { return path_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string path_;
  std::string reason_;
};

class AtomicOutput {
 public:
  // Creates the temporary file; throws OutputError naming `path` when it cannot (no such
  // folder, no permission, a full disk).
  explicit AtomicOutput(std::string path);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  // Appends `bytes`; throws OutputError on a failed write.
  void write(std::string_view bytes);
  // The temporary file as a stdio stream, for writers that format into a FILE* (fprintf,
  // a JSON stream). Errors stick to the stream; commit() finds them.
  std::FILE* stream() const { return file_; }
  // Records a failure found by a writer that does not use errno (a library's status):
  // commit() then throws with `reason` and the target is left alone.
  void fail(std::string reason);

  // Flushes, syncs and closes the temporary, then renames it over the target. Throws
  // OutputError (and removes the temporary) if any write failed. Call once.
  void commit();

  const std::string& path() const { return path_; }
  const std::string& temp_path() const { return temp_; }

 private:
  [[noreturn]] void give_up(const std::string& reason);
  std::string path_, target_, temp_;  // target_: path_, or the file a symbolic link names
  std::FILE* file_ = nullptr;
  std::string failure_;
  bool committed_ = false;
};

// The common case: `bytes` as the whole new content of `path`, atomically.
void write_file_atomically(const std::string& path, std::string_view bytes);

}  // namespace machplan
