// host_id fit's command line: what it gives (FitArguments), its options,
// and the FitOptions they stand for (commands/fit.cpp runs them).
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "host_id/identify.hpp"
#include "host_id/model_support.hpp"

namespace host_id::fit_cli {

// What the command line gives, before it becomes FitOptions.
struct FitArguments {
  std::string log;
  FitOptions fit;
  std::string method{"pso"};
  std::string topology{"gbest"};
  std::string solver{"qr"};
  std::string weights{"none"};
  std::size_t trim{0};
  double min_speed_rad_s{0};
  std::vector<std::string> models{"auto"};  // the first is the primary model
  std::vector<std::string> validate;
  std::string out_path;
  std::string plot_path;
  std::string truth_path;
  bool json{false};
  bool quiet{false};
  bool allow_other_geometry{false};
  std::string time_steps{"check"};
  std::string state_cutoff{"auto"};
  std::optional<ModelSelection> selection;           // with --model auto
  std::string base_path;                             // --base: a payload on this fit
  std::string calibrate_path;                        // --calibrate-torque: the loaded log
  double payload_mass_kg{0};                         // --payload-mass, with --calibrate-torque
  std::vector<double> gearbox_stiffness_Nm_per_rad;  // --gearbox-stiffness: 1 or 3 values
  std::vector<double> cogging_periods;               // --cogging-periods: 1 or 3 values
  CLI::Option* model_given{nullptr};
  CLI::Option* trim_given{nullptr};
  CLI::Option* min_speed_given{nullptr};
};

// The model, estimator, sample and output options, into `a`.
void add_fit_options(CLI::App& c, FitArguments& a);

// The options the strings and the optional values stand for. Throws
// UsageError for values that go together badly (two stiffnesses, two
// cogging periods).
FitOptions fit_options(const FitArguments& a);

}  // namespace host_id::fit_cli
