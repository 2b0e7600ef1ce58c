// Output that cannot lose data silently.
//
//   * print_json(): --json output, streamed (cli/json/json_stream.h), never held whole
//     as text. nlohmann's dump() throws on a string that is not valid UTF-8 (a Latin-1 layer
//     name, a file name in a legacy encoding); here each invalid byte becomes U+FFFD instead
//     and a warning on stderr says so, so --json output is always valid UTF-8. Output that
//     grows with the input without being built first (program moves) uses a JsonStream
//     directly and finish_json() for the warning.
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

#include "cli/json/json_stream.h"

namespace machplan::cli {

// After a streamed document: the warning when text was replaced. A failed write needs nothing
// here: stdout keeps its error, and main() turns it into exit 1 with the reason.
void finish_json(const JsonStream& out);

// Writes `doc` to stdout followed by a newline, streamed: its top-level members one at a time,
// and the elements of a top-level array member one at a time, never the whole text at once.
// For documents already built whose arrays grow with the input (run cuts, profile contours).
void print_json(const nlohmann::json& doc, int indent = 2);

void refuse_overwriting_input(const std::string& flag, const std::string& output,
                              std::initializer_list<std::string> inputs);

void check_output_folder(const std::string& flag, const std::string& output);

}  // namespace machplan::cli
