#include "engine/common/text_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "engine/common/error.h"

namespace machplan {

std::string read_text_file(const std::string& path, std::size_t max_bytes) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw InputError(path, 0, "cannot open file: no such file");
  if (std::filesystem::is_directory(status)) throw InputError(path, 0, "is a directory, expected a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open file for reading");
  in.seekg(0, std::ios::end);
  const auto size = in.tellg();
  if (size < 0) throw InputError(path, 0, "cannot determine the file size");
  if (static_cast<std::size_t>(size) > max_bytes)
    throw InputError(path, 0, fmt::format("file is {} bytes, more than the limit of {} bytes",
                                          static_cast<long long>(size), max_bytes));
  in.seekg(0, std::ios::beg);
  std::string text(static_cast<std::size_t>(size), '\0');
  in.read(text.data(), size);
  if (!in) throw InputError(path, 0, "read failed");
  return text;
}

}  // namespace machplan
