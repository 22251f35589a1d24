// The real programs of the HIL pipeline tests, started on the test's vcan
// interface: delta_drive_emu (drives and robot), delta_fw (the firmware's
// Linux port) and host_id record.
#pragma once

#include <string>
#include <vector>

#include "child_process.hpp"
#include "vcan_interface.hpp"

namespace hil {

inline const std::string kIface = vcan_interface();
inline const std::string kBin = DELTA_BIN_DIR;
inline const std::string kSource = DELTA_SOURCE_DIR;

Child start_emulator(const std::vector<std::string>& extra = {});

// delta_fw in lock-step running path1 once and exiting when it is done;
// `extra` are more of its options. `periods`: the Fourier periods, where a
// test needs a whole run but not the preset's two (0: the preset's).
Child start_path1_firmware(const std::vector<std::string>& extra = {}, int periods = 0);

// host_id record on the bus, writing `csv` when the log frames stop for 3 s.
Child start_recorder(const std::string& csv);

// delta_fw in lock-step with its Modbus TCP server on loopback `port`, once
// it is ready.
Child start_firmware_with_modbus(int port, const std::vector<std::string>& extra = {});

// The controller's and the emulator's own words, once both are stopped: a
// failed excite's report needs them beside host_id's (which drive faulted,
// and why).
std::string stopped_and_told(Child& fw, Child& emu);

// The worst joint's RMS of each `arm tracking` line delta_drive_emu printed
// (one after each run), in the order of the runs.
std::vector<double> worst_arm_tracking(const std::string& emulator_said);

}  // namespace hil
