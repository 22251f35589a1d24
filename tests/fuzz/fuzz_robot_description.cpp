// libFuzzer harness: the robot description reader (docs/robot-description.md)
// and, for what it accepts, the truths derived from it and the MuJoCo model
// built from it. Errors are delta::InputError; an accepted robot must give
// finite truths and a model MuJoCo loads.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "delta/input_error.hpp"
#include "delta/mujoco_plant.hpp"
#include "delta/robot_description.hpp"
#include "scratch_directory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path =
      testsupport::process_scratch("fuzz_robot_description").file("robot.json");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    const delta::RobotDescription d = delta::read_robot_description(path);
    const delta::LumpedParameters l = delta::lumped_truth(d);
    if (!std::isfinite(l.arm_inertia_kg_m2[0]) || !std::isfinite(l.platform_mass_kg)) std::abort();
    const delta::MujocoPlant plant(d, {0.0, 0.0, 0.0});
    (void)plant;
  } catch (const delta::InputError&) {
  }
  return 0;
}
