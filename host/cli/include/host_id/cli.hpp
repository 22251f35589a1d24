// The host_id command line: parses arguments, runs a subcommand, prints.
// main() only calls run_cli().
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace host_id {

// Exit status: 0 success, 1 bad input or a failed run, 2 bad usage.
int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace host_id
