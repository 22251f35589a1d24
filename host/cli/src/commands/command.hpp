// What every host_id command is made of: it gives its subcommand (CLI11;
// named in cli.cpp's table of commands) its description and options, and
// the subcommand's callback runs it and sets the exit status.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "delta/hex.hpp"
#include "delta/input_error.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

struct CommandContext {
  std::ostream& out;
  std::ostream& err;
  int exit_code{0};
};

// A usage error found after parsing (options that contradict each other, a
// file name of the wrong kind): exit status 2, like CLI11's parse errors.
class UsageError : public delta::InputError {
 public:
  using delta::InputError::InputError;
};

// Validators for CLI11 options. Numbers must be finite ("inf" and "nan"
// are refused; CLI::Range lets NaN through).
extern const CLI::Validator kFinite;
extern const CLI::Validator kPositive;     // > 0
extern const CLI::Validator kNonNegative;  // >= 0
// lo <= v <= hi, or lo <= v < hi when open_above.
CLI::Validator finite_range(double lo, double hi, bool open_above = false);
// HOST:PORT with a port from 1 to 65535.
extern const CLI::Validator kHostPort;
// A file name ending in .svg.
extern const CLI::Validator kSvgPath;
// A file the command will write: its folder exists and is writable
// (delta::output_path_problem), checked before any work.
extern const CLI::Validator kOutputPath;

// Throws UsageError where `out` (given as `option`) names the same file as
// one of the command's inputs: the input would be overwritten by what is
// made from it.
void refuse_writing_over_input(const std::string& out, const char* option,
                               const std::vector<std::string>& inputs);

// --time-steps nominal|as-logged (docs/preprocessing.md, "Timestamps"):
// how the samples' times are taken where q is differentiated; `given`
// tells whether the option was on the command line.
CLI::Option* add_time_steps_option(CLI::App& c, std::string& value);
TimeSteps time_steps_named(const std::string& value);

// Exit statuses of the commands that talk SDO to a node (sdo, flash):
// the node aborted the transfer, or it did not answer.
constexpr int kExitSdoAborted = 3;
constexpr int kExitNoAnswer = 4;

using delta::hex32;

void add_fit_command(CLI::App& app, CommandContext& context);
void add_validate_command(CLI::App& app, CommandContext& context);
void add_predict_command(CLI::App& app, CommandContext& context);
void add_design_command(CLI::App& app, CommandContext& context);
void add_simulate_command(CLI::App& app, CommandContext& context);
void add_record_command(CLI::App& app, CommandContext& context);
void add_excite_command(CLI::App& app, CommandContext& context);
void add_status_command(CLI::App& app, CommandContext& context);
void add_dbc_command(CLI::App& app, CommandContext& context);
void add_sdo_command(CLI::App& app, CommandContext& context);
void add_image_command(CLI::App& app, CommandContext& context);
void add_flash_command(CLI::App& app, CommandContext& context);
void add_model_command(CLI::App& app, CommandContext& context);

}  // namespace host_id
