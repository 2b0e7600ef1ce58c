// Reading a user's input file whole, with limits, so that no file can exhaust memory.
#pragma once

#include <cstddef>
#include <string>

namespace machplan {

// Default cap on any input file read into memory: 512 MiB.
inline constexpr std::size_t kMaxInputBytes = std::size_t{512} << 20;

// Reads `path` into a string. Throws InputError naming the file when it cannot be opened
// (with the system's reason), is not a regular file (a folder, a FIFO, a device such as
// /dev/zero, a socket: refused at once, never waited on), or is larger than `max_bytes`.
std::string read_text_file(const std::string& path, std::size_t max_bytes = kMaxInputBytes);

}  // namespace machplan
