// The command line end to end, through run_cli() with real files: the
// fixture of the cli_*_test.cpp files (host_tests).
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "host_id/cli.hpp"
#include "scratch_directory.hpp"

namespace host_id::cli_test {

class CliTest : public ::testing::Test {
 protected:
  int run(const std::vector<std::string>& args) {
    out_.str("");
    err_.str("");
    return run_cli(args, out_, err_);
  }
  std::string path(const std::string& name) const { return dir_ + "/" + name; }
  bool exists(const std::string& name) const { return std::filesystem::exists(path(name)); }
  void simulate(const std::string& name, const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args{"simulate", "-o", path(name), "--duration", "4"};
    args.insert(args.end(), extra.begin(), extra.end());
    ASSERT_EQ(run(args), 0) << err_.str();
  }
  // A lumped log of arms whose inertias and gravity moments differ by up to
  // 5 % (simulate --params with per-joint values).
  void simulate_arms_that_differ(const std::string& name) {
    std::ofstream(path("arms.json"))
        << R"({"arm_inertia_1": 0.0076, "arm_inertia_2": 0.0072, "arm_inertia_3": 0.0068,
               "arm_gravity_moment_1": 0.42, "arm_gravity_moment_2": 0.44,
               "arm_gravity_moment_3": 0.46, "platform_mass": 0.4})";
    simulate(name, {"--params", path("arms.json"), "--torque-noise", "0.01"});
  }

  const testsupport::ScratchDirectory scratch_{"host_id_cli"};
  const std::string dir_ = scratch_.path();
  std::ostringstream out_, err_;
};

}  // namespace host_id::cli_test
