#include "port_test_support.hpp"

#include <fstream>

#include "scratch_directory.hpp"

namespace fw_linux::port_test {

std::string scratch_file(const std::string& name) {
  return testsupport::process_scratch("port_test").file(name);
}

std::string write_temp(const std::string& text) {
  std::string path = scratch_file("port_test.conf");
  std::ofstream(path) << text;
  return path;
}

bool bring_up(Rig& rig) {
  for (int n = 0; n < 50 && rig.controller.state() != fw::State::kReady; ++n) rig.cycle();
  return rig.controller.state() == fw::State::kReady;
}

}  // namespace fw_linux::port_test
