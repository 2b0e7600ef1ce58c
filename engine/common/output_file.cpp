#include "engine/common/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

namespace machplan {

namespace {
std::atomic<unsigned> g_output_temp_serial{0};
}  // namespace

AtomicOutput::AtomicOutput(std::string path) : path_(std::move(path)), target_(path_) {
  namespace fs = std::filesystem;
  struct stat existing {};
  if (::stat(path_.c_str(), &existing) == 0 && !S_ISREG(existing.st_mode)) {
    if (S_ISDIR(existing.st_mode)) throw OutputError(path_, "it is a folder, not a file");
    // A device or a FIFO (/dev/stdout, a pipe a reader waits on): there is no old content to
    // keep and no folder to put a temporary in; written straight through.
    const int fd = ::open(path_.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
    if (fd < 0 || !(file_ = ::fdopen(fd, "wb"))) {
      const int err = errno;
      if (fd >= 0) ::close(fd);
      throw OutputError(path_, std::strerror(err));
    }
    return;
  }
  // A symbolic link to a file: the file it names is replaced, the link stays.
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(path_, ec))) {
    const fs::path real = fs::canonical(path_, ec);
    if (!ec) target_ = real.string();
  }
  const fs::path target(target_);
  if (!target.has_filename()) throw OutputError(path_, "the name is a folder, not a file");
  const fs::path dir = target.parent_path();
  // O_EXCL on a name no other process uses (the pid) and no other writer of this one (the
  // serial): the temporary is ours alone. Mode 0666: the kernel applies the umask.
  int fd = -1;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    temp_ = (dir / fmt::format(".{}.tmp-{}-{}", target.filename().string(), ::getpid(),
                               g_output_temp_serial.fetch_add(1)))
                .string();
    fd = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) {
    const int err = errno;
    temp_.clear();
    throw OutputError(path_, std::strerror(err));
  }
  // A file replaced keeps its permissions.
  struct stat old {};
  if (::stat(target_.c_str(), &old) == 0 && S_ISREG(old.st_mode)) (void)::fchmod(fd, old.st_mode & 07777);
  file_ = ::fdopen(fd, "wb");
  if (!file_) {
    const int err = errno;
    ::close(fd);
    ::unlink(temp_.c_str());
    temp_.clear();
    throw OutputError(path_, std::strerror(err));
  }
}

AtomicOutput::~AtomicOutput() {
  if (file_) std::fclose(file_);
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicOutput::write(std::string_view bytes) {
  if (!failure_.empty()) give_up(failure_);
  if (!file_) give_up("the file is already closed");
  if (bytes.empty()) return;
  errno = 0;
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    give_up(std::strerror(errno != 0 ? errno : EIO));
  }
}

void AtomicOutput::fail(std::string reason) {
  if (failure_.empty()) failure_ = std::move(reason);
}

void AtomicOutput::give_up(const std::string& reason) {
  if (failure_.empty()) failure_ = reason;  // the first reason is the one commit() reports
  if (file_) std::fclose(file_);
  file_ = nullptr;
  if (!temp_.empty()) ::unlink(temp_.c_str());
  temp_.clear();
  throw OutputError(path_, reason);
}

void AtomicOutput::commit() {
  if (!failure_.empty()) give_up(failure_);
  if (committed_ || !file_) give_up("the file was already written");
  // A write that failed inside fprintf left its mark on the stream, not its errno: flush
  // again to find the reason (the buffer still holds what could not be written).
  errno = 0;
  if (std::fflush(file_) != 0 || std::ferror(file_)) {
    int err = errno;
    // The stream's error came from an earlier write whose errno is gone: one more byte written
    // straight to the temporary (which is thrown away) finds the reason again.
    if (err == 0 && !temp_.empty() && ::write(::fileno(file_), "\n", 1) < 0) err = errno;
    give_up(std::strerror(err != 0 ? err : EIO));
  }
  if (!temp_.empty() && ::fsync(::fileno(file_)) != 0) give_up(std::strerror(errno));
  const int closed = std::fclose(file_);
  const int close_err = errno;
  file_ = nullptr;
  if (closed != 0) give_up(std::strerror(close_err));
  if (temp_.empty()) {  // a device or a FIFO, written straight through
    committed_ = true;
    return;
  }
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) give_up(std::strerror(errno));
  committed_ = true;
}

void write_file_atomically(const std::string& path, std::string_view bytes) {
  AtomicOutput out(path);
  out.write(bytes);
  out.commit();
}

}  // namespace machplan
