// host_id fit on a log recorded in a HIL test, and its parameters checked
// against the truth of the robot the emulator ran.
#pragma once

#include <string>
#include <vector>

namespace hil {

struct ParameterCheck {
  std::string name;
  double truth;
  double tolerance;  // relative
};

// Fits a log (PSO, the default) with a model and compares the named
// parameters with their truth.
void expect_fit_near(const std::string& log, const std::string& dir, const std::string& model,
                     const std::vector<ParameterCheck>& checks);

// The lumped plant's truth: every parameter of the lumped model, which is
// the plant's own.
void expect_fit_matches_truth(const std::string& log, const std::string& dir);

// The multibody robot against the default (higher-fidelity) model, which
// contains it but for the friction's shape: its arm and platform
// parameters with bounds of about three of their standard deviations on
// path1 (docs/dev/hil-tests.md; offline on the demo's path1: +1.3 % (std dev 4.2 %),
// -0.4 % (0.3 %), +0.9 % (4.9 %), -0.03 % (1.0 %), +0.4 % (0.35 %)), the
// Coulomb levels within 25 % (the Stribeck excess adds to them: +10 %).
// The viscous friction absorbs the friction's shape: printed, not checked.
void expect_fit_stands_for_the_multibody_robot(const std::string& log, const std::string& dir);

}  // namespace hil
