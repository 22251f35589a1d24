// What the firmware_port_tests' files share: files of this process's own
// and the in-process rig brought up.
#pragma once

#include <string>

#include "in_process_rig.hpp"

namespace fw_linux::port_test {

// A file in this process's own scratch directory (removed at exit).
std::string scratch_file(const std::string& name);

// `text` written to port_test.conf in the scratch directory; its path.
std::string write_temp(const std::string& text);

// Runs the rig's cycles until the controller is ready (bounded).
bool bring_up(Rig& rig);

}  // namespace fw_linux::port_test
