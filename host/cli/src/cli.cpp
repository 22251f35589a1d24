#include "host_id/cli.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <new>
#include <ostream>

#include "commands/command.hpp"
#include "delta/atomic_file.hpp"
#include "host_id/controller_link.hpp"

namespace host_id {

namespace {

// The commands by name, in the order `host_id --help` lists them; each
// adds its description, options and callback to its subcommand.
struct Command {
  const char* name;
  const char* summary;  // its line in `host_id --help`; its own --help says all
  void (*add)(CLI::App& command, CommandContext& context);
};
constexpr std::array kCommands{
    Command{"fit", "estimate the dynamic parameters from a log", add_fit_command},
    Command{"validate", "a saved fit's torque RMSE on more logs", add_validate_command},
    Command{"predict", "the model's torque at every sample of a log", add_predict_command},
    Command{"design", "design an excitation trajectory for your robot", add_design_command},
    Command{"simulate", "write a log of a simulated robot, with known truth", add_simulate_command},
    Command{"record", "record the controller's CAN log into a log", add_record_command},
    Command{"excite", "run an excitation on the controller and record it", add_excite_command},
    Command{"status", "the controller's state, faults and settings (Modbus)", add_status_command},
    Command{"sdo", "read or write any node's object by SDO", add_sdo_command},
    Command{"dbc", "write the CAN bus's DBC description", add_dbc_command},
    Command{"image", "make, sign and check firmware images", add_image_command},
    Command{"flash", "update the controller's firmware over CAN", add_flash_command},
    Command{"model", "load the identified model into the controller, or show it",
            add_model_command}};

// The command args name first, if any.
const Command* named_command(const std::vector<std::string>& args) {
  for (const Command& command : kCommands) {
    if (!args.empty() && args[0] == command.name) return &command;
  }
  return nullptr;
}

// The subcommands to parse args with: only the one args name first (all
// twelve with their options took 1.2 ms of every command's start), or all
// of them for the top level's help, version and usage errors.
void add_commands(CLI::App& app, const Command* chosen, CommandContext& context) {
  for (const Command& command : kCommands) {
    if (chosen != nullptr && chosen != &command) continue;
    CLI::App* sub = app.add_subcommand(command.name);
    command.add(*sub, context);
    sub->fallthrough();
    // The top level lists each command in a line; its own --help has all.
    if (chosen == nullptr) sub->description(command.summary);
  }
}

constexpr const char* kDescription =
    "Identifies the dynamic parameters of a delta parallel robot from delta-log/1 files "
    "(docs/log-format.md). 'host_id <command> --help' describes a command's options.";

std::string which_command(const CLI::App& app) {
  const auto chosen = app.get_subcommands();
  return chosen.empty() ? std::string("host_id") : "host_id " + chosen.front()->get_name();
}

// The edit distance between a and b: insertions, deletions, substitutions
// and swaps of two neighbours ("fti" is one edit from "fit").
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min(
          {d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    }
  }
  return d[a.size()][b.size()];
}

// The candidate closest to `word`, if it is close enough to be a slip of
// the keyboard: at most 2 edits, and at most a third of its letters.
std::string closest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = 3;
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_distance && 3 * d <= std::max<std::size_t>(word.size(), 3)) {
      best = c;
      best_distance = d;
    }
  }
  return best;
}

// " (did you mean --method?)" for the first argument CLI11 did not expect
// that looks like a misspelt option of the command; "" otherwise.
std::string option_suggestion(const CLI::App& app, const std::vector<std::string>& args) {
  const auto chosen = app.get_subcommands();
  if (chosen.empty()) return "";
  std::vector<std::string> names;
  for (const CLI::Option* o : chosen.front()->get_options()) {
    for (const std::string& n : o->get_lnames()) names.push_back("--" + n);
  }
  for (const CLI::App* sub : chosen.front()->get_subcommands({})) names.push_back(sub->get_name());
  for (const std::string& a : args) {
    if (!a.starts_with("--")) continue;
    const std::string word = a.substr(0, a.find('='));
    if (std::find(names.begin(), names.end(), word) != names.end()) continue;
    if (const std::string near = closest(word, names); !near.empty()) {
      return " (did you mean " + near + "?)";
    }
  }
  return "";
}

std::string version_text() {
  return std::string("host_id ") + DELTA_VERSION;
}

// A finite number, or why not.
std::string finite_number(const std::string& s, double& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || !std::isfinite(v)) {
    return "expects a finite number, got '" + s + "'";
  }
  return {};
}

CLI::Validator number_where(std::function<bool(double)> ok, const std::string& description) {
  return CLI::Validator(
      [ok, description](std::string& s) -> std::string {
        double v = 0;
        if (auto why = finite_number(s, v); !why.empty()) return why;
        return ok(v) ? std::string() : "must be " + description + ", got '" + s + "'";
      },
      description);
}

}  // namespace

void refuse_writing_over_input(const std::string& out, const char* option,
                               const std::vector<std::string>& inputs) {
  if (out.empty()) return;
  std::error_code ec;
  for (const std::string& in : inputs) {
    const bool same =
        std::filesystem::exists(out, ec) ? std::filesystem::equivalent(out, in, ec) : false;
    if (same) {
      throw UsageError(std::string(option) + " " + out + " is the input " + in +
                       ": it would be overwritten by what is made from it; write to another file");
    }
  }
}

const CLI::Validator kFinite = number_where([](double) { return true; }, "finite");
const CLI::Validator kPositive = number_where([](double v) { return v > 0; }, "> 0");
const CLI::Validator kNonNegative = number_where([](double v) { return v >= 0; }, ">= 0");

CLI::Option* add_time_steps_option(CLI::App& c, std::string& value) {
  return c
      .add_option("--time-steps", value,
                  "where q is differentiated: 'check' refuses time steps that spread more than "
                  "5 %; 'nominal' takes the samples as even, at the declared rate or the mean step "
                  "(their timestamps jitter); 'as-logged' differentiates on the timestamps")
      ->check(CLI::IsMember({"check", "nominal", "as-logged"}));
}

TimeSteps time_steps_named(const std::string& value) {
  return value == "nominal"     ? TimeSteps::kNominal
         : value == "as-logged" ? TimeSteps::kAsLogged
                                : TimeSteps::kCheck;
}

CLI::Validator finite_range(double lo, double hi, bool open_above) {
  const std::string description = "in [" + CLI::detail::to_string(lo) + ", " +
                                  CLI::detail::to_string(hi) + (open_above ? ")" : "]");
  return number_where([=](double v) { return v >= lo && (open_above ? v < hi : v <= hi); },
                      description);
}

const CLI::Validator kHostPort(
    [](std::string& s) -> std::string {
      try {
        parse_host_port(s);
      } catch (const delta::InputError& e) {
        return e.what();
      }
      return {};
    },
    "HOST:PORT");

const CLI::Validator kSvgPath(
    [](std::string& s) -> std::string {
      if (s.size() < 4 || s.substr(s.size() - 4) != ".svg") {
        return "writes SVG; give a file name ending in .svg, got '" + s + "'";
      }
      return {};
    },
    "FILE.svg");

const CLI::Validator kOutputPath(
    [](std::string& s) -> std::string { return delta::output_path_problem(s); }, "FILE");

int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  CommandContext context{out, err};
  CLI::App app(kDescription, "host_id");
  app.set_version_flag("--version", version_text(), "print the version and exit");
  app.require_subcommand(1);
  const Command* chosen = named_command(args);
  if (chosen == nullptr && !args.empty() && !args[0].starts_with('-')) {
    std::string names;
    for (const Command& command : kCommands)
      names += (names.empty() ? "" : ", ") + std::string(command.name);
    std::vector<std::string> all;
    for (const Command& command : kCommands) all.emplace_back(command.name);
    const std::string near = closest(args[0], all);
    err << "host_id: error: unknown command '" << args[0] << "'"
        << (near.empty() ? "" : " (did you mean '" + near + "'?)") << "; the commands are " << names
        << " (see host_id --help)\n";
    return 2;
  }
  add_commands(app, chosen, context);
  // CLI11 takes the arguments in reverse order.
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);
    return context.exit_code;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e, out, err);  // --help, --version
    if (args.empty()) err << app.help();
    const std::string command = which_command(app);
    err << command << ": error: " << e.what() << option_suggestion(app, args) << " (see " << command
        << " --help)\n";
    return 2;
  } catch (const UsageError& e) {
    err << which_command(app) << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    err << which_command(app) << ": error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {  // delta::InputError: bad input, named where
    err << which_command(app) << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace host_id
