// Output that cannot lose data silently.
//
//   * json_text(): nlohmann's dump() throws on a string that is not valid UTF-8 (a Latin-1
//     layer name, a file name in a legacy encoding). json_text() replaces each invalid byte by
//     U+FFFD instead and says so on stderr, so --json output is always valid UTF-8.
//   * refuse_overwriting_input(): an output path (--plot, --trace) that names one of the
//     command's input files is refused with InputError before any work is done.
//   * check_output_folder(): the folder an output file goes to exists, checked before a long
//     run, not after it.
//   * Writes to stdout are checked once, in main(): after the command it flushes stdout and
//     turns any write error into exit 1 with the reason (`> /dev/full`, a closed pipe).
#pragma once

#include <initializer_list>
#include <string>

#include <nlohmann/json.hpp>

namespace machplan::cli {

std::string json_text(const nlohmann::json& j, int indent = -1);

void refuse_overwriting_input(const std::string& flag, const std::string& output,
                              std::initializer_list<std::string> inputs);

void check_output_folder(const std::string& flag, const std::string& output);

}  // namespace machplan::cli
