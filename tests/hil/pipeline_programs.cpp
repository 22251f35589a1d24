#include "pipeline_programs.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <sstream>

namespace hil {

using namespace std::chrono_literals;

Child start_emulator(const std::vector<std::string>& extra) {
  std::vector<std::string> argv{kBin + "/delta_drive_emu", "--can", kIface};
  argv.insert(argv.end(), extra.begin(), extra.end());
  Child emu = Child::spawn(argv);
  if (!emu.wait_for_output("ready on " + kIface, 30s)) {
    ADD_FAILURE() << "the emulator did not come up: " << emu.err();
  }
  return emu;
}

Child start_path1_firmware(const std::vector<std::string>& extra, int periods) {
  const std::string run = periods > 0 ? "path1:" + std::to_string(periods) : "path1";
  std::vector<std::string> argv{kBin + "/delta_fw", "--can", kIface, "--lockstep", "--run", run,
                                "--exit-when-done"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return Child::spawn(argv);
}

Child start_recorder(const std::string& csv) {
  Child rec =
      Child::spawn({kBin + "/host_id", "record", "--can", kIface, "-o", csv, "--idle", "3"});
  if (!rec.wait_for_output("listening on", 30s)) {
    ADD_FAILURE() << "the recorder did not start: " << rec.err();
  }
  return rec;
}

Child start_firmware_with_modbus(int port, const std::vector<std::string>& extra) {
  std::vector<std::string> argv{
      kBin + "/delta_fw", "--can", kIface,
      "--lockstep",       "--set", "modbus.tcp=127.0.0.1:" + std::to_string(port)};
  argv.insert(argv.end(), extra.begin(), extra.end());
  Child fw = Child::spawn(argv);
  if (!fw.wait_for_output("delta_fw: ready", 60s)) {
    ADD_FAILURE() << "delta_fw did not become ready: " << fw.err();
  }
  return fw;
}

std::string stopped_and_told(Child& fw, Child& emu) {
  fw.terminate(30s);
  emu.terminate(30s);
  return "\n--- delta_fw:\n" + fw.err() + "\n--- delta_drive_emu:\n" + emu.err();
}

std::vector<double> worst_arm_tracking(const std::string& emulator_said) {
  std::vector<double> worst;
  std::istringstream lines(emulator_said);
  for (std::string line; std::getline(lines, line);) {
    double rms[3] = {};
    if (std::sscanf(line.c_str(), "arm tracking: rms_rad=%lf,%lf,%lf", &rms[0], &rms[1], &rms[2]) ==
        3) {
      worst.push_back(std::max({rms[0], rms[1], rms[2]}));
    }
  }
  return worst;
}

}  // namespace hil
