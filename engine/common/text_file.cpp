#include "engine/common/text_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "engine/common/error.h"

namespace machplan {

namespace {

// What a path that is not a regular file is, in the words of a message.
const char* kind_of_special_file(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// Closes the descriptor on every way out of read_text_file.
struct InputFd {
  int fd = -1;
  ~InputFd() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

std::string read_text_file(const std::string& path, std::size_t max_bytes) {
  // O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer, for ever; with
  // it the open returns at once and fstat() says what the file is. Nothing but a regular file
  // is read: a FIFO or a device (/dev/zero) has no end or no size to check against the limit.
  InputFd in;
  in.fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (in.fd < 0) {
    const int err = errno;
    if (err == ENOENT) throw InputError(path, 0, "cannot open file: no such file");
    throw InputError(path, 0, fmt::format("cannot open file for reading: {}", std::strerror(err)));
  }
  struct stat st {};
  if (::fstat(in.fd, &st) != 0) throw InputError(path, 0, fmt::format("cannot read file: {}", std::strerror(errno)));
  if (S_ISDIR(st.st_mode)) throw InputError(path, 0, "is a folder, expected a file");
  if (!S_ISREG(st.st_mode))
    throw InputError(path, 0, fmt::format("is {}, not a regular file; machplan reads input only from regular files",
                                          kind_of_special_file(st.st_mode)));
  const auto size = static_cast<std::size_t>(st.st_size);
  if (size > max_bytes)
    throw InputError(path, 0, fmt::format("file is {} bytes, more than the limit of {} bytes",
                                          static_cast<long long>(st.st_size), max_bytes));
  std::string text(size, '\0');
  std::size_t got = 0;
  while (got < size) {
    const ssize_t n = ::read(in.fd, text.data() + got, size - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw InputError(path, 0, fmt::format("read failed: {}", std::strerror(errno)));
    if (n == 0) break;  // the file shrank while it was read: what is there
    got += static_cast<std::size_t>(n);
  }
  text.resize(got);
  return text;
}

}  // namespace machplan
