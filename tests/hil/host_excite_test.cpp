// host_id excite on vcan with the real programs: Modbus TCP to the
// controller and the CAN log, on the multibody (MuJoCo) robot, which no
// model contains exactly; then the fit, and the fitted model as the
// controller's feed-forward.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "fit_checks.hpp"
#include "pipeline_programs.hpp"
#include "recorded_log.hpp"
#include "scratch_directory.hpp"

namespace {

using hil::expect_every_record_accounted_for;
using hil::expect_fit_stands_for_the_multibody_robot;
using hil::kBin;
using hil::kIface;
using hil::start_emulator;
using hil::start_firmware_with_modbus;
using hil::stopped_and_told;
using hil::sum_of_numbers;
using hil::worst_arm_tracking;
using namespace std::chrono_literals;

// The controller's tracking error of the run, in the log's metadata.
void expect_tracking_in_the_metadata(const std::string& text) {
  for (const char* key : {"# tracking_rms_rad_1 = ", "# tracking_max_rad_3 = "}) {
    const std::size_t at = text.find(key);
    ASSERT_NE(at, std::string::npos) << key;
    const double v = std::strtod(text.c_str() + at + std::strlen(key), nullptr);
    EXPECT_GT(v, 0.0) << key;
    EXPECT_LT(v, 0.05) << key;
  }
}

// The index of `name` in a CSV header line; -1 if it has none.
int column_of(const std::string& header, const std::string& name) {
  std::istringstream h(header);
  std::string c;
  for (int k = 0; std::getline(h, c, ','); ++k)
    if (c == name) return k;
  return -1;
}

// The drives' currents came with every one of the `recorded` samples: the
// logged torque is the firmware's gear * k_t * efficiency * i =
// 10 * 0.1 * 0.9 * i.
void expect_currents_with_every_sample(const std::string& text, std::uint64_t recorded) {
  std::istringstream rows(text);
  std::string line;
  while (std::getline(rows, line) && line[0] == '#') {
  }
  ASSERT_NE(line.find(",i1,i2,i3"), std::string::npos) << line;
  const int tau1 = column_of(line, "tau1");
  const int i1 = column_of(line, "i1");
  double worst = 0;
  std::size_t n = 0;
  while (std::getline(rows, line)) {
    std::vector<double> v;
    std::istringstream r(line);
    for (std::string f; std::getline(r, f, ',');) v.push_back(std::stod(f));
    worst = std::max(worst, std::fabs(v[static_cast<std::size_t>(tau1)] -
                                      0.9 * v[static_cast<std::size_t>(i1)]));
    ++n;
  }
  EXPECT_EQ(n, recorded);
  EXPECT_LT(worst, 2e-5) << "tau1 and i1 of the same sample";
}

// host_id status after path1's run: finished, and its tracking.
void expect_status_after_the_run(const std::string& modbus) {
  hil::Child after = hil::Child::spawn({kBin + "/host_id", "status", "--modbus", modbus});
  ASSERT_EQ(after.wait(30s).value_or(-1), 0) << after.err();
  EXPECT_NE(after.out().find("run        #1 finished, tick 7001 of 7001"), std::string::npos)
      << after.out();
  EXPECT_NE(after.out().find("  tracking   run #1, rms "), std::string::npos) << after.out();
}

// One rig on the multibody robot for the two tests that need path1 run on
// it: the emulator, the controller with Modbus and a model store, and
// path1 excited and recorded once (most of a minute in the VM). Made by
// the first of the two tests that runs, kept until the process ends.
struct MultibodySession {
  const testsupport::ScratchDirectory scratch{"delta_hil"};
  const std::string dir = scratch.path();
  const std::string modbus = "127.0.0.1:15021";
  hil::Child emu = start_emulator();
  hil::Child fw =
      start_firmware_with_modbus(15021, {"--set", "feed_forward.store=" + dir + "/model.bin"});
  std::string status_before;  // host_id status before the run
  int excite_exit = -1;
  std::string excite_said;  // host_id excite's stdout and stderr

  MultibodySession() {
    hil::Child status = hil::Child::spawn({kBin + "/host_id", "status", "--modbus", modbus});
    if (status.wait(30s).value_or(-1) == 0) status_before = status.out();
    hil::Child excite =
        hil::Child::spawn({kBin + "/host_id", "excite", "--modbus", modbus, "--trajectory", "path1",
                           "--can", kIface, "-o", dir + "/path1.csv"});
    excite_exit = excite.wait(300s).value_or(-1);
    excite_said = excite.out() + excite.err();
    std::cout << excite.out();
  }
  std::string told() { return excite_said + stopped_and_told(fw, emu); }
};

MultibodySession& multibody_session() {
  static MultibodySession session;
  return session;
}

TEST(HostExcite, RunsPath1OnTheMultibodyRobotOverModbusRecordsItAndFitsIt) {
  MultibodySession& s = multibody_session();
  EXPECT_NE(s.status_before.find("state      ready"), std::string::npos) << s.status_before;
  EXPECT_NE(s.status_before.find("run        none since start"), std::string::npos)
      << s.status_before;
  ASSERT_EQ(s.excite_exit, 0) << s.told();
  const std::string& said = s.excite_said;
  const std::uint64_t recorded = sum_of_numbers(said, " recorded of", false);
  EXPECT_EQ(sum_of_numbers(said, "recorded of ", true), 7201u) << said;
  EXPECT_NE(said.find("sent, 0 lost, "), std::string::npos) << said;
  expect_every_record_accounted_for(said, recorded, 7201);
  std::ifstream log(s.dir + "/path1.csv");
  std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("# trajectory = path1"), std::string::npos);
  EXPECT_NE(text.find("# sample_rate_hz = 500"), std::string::npos);
  ASSERT_NO_FATAL_FAILURE(expect_tracking_in_the_metadata(text));
  ASSERT_NO_FATAL_FAILURE(expect_currents_with_every_sample(text, recorded));
  ASSERT_NO_FATAL_FAILURE(expect_status_after_the_run(s.modbus));
  EXPECT_TRUE(s.fw.wait_for_output("tracking path1: rms_rad=", 10s)) << s.fw.err();
  expect_fit_stands_for_the_multibody_robot(s.dir + "/path1.csv", s.dir);
}

// The controller's tracking error of a recorded run, from its log's
// metadata: the worst joint's RMS.
double worst_tracking_rms(const std::string& csv) {
  std::ifstream in(csv);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  double worst = 0.0;
  for (const char* j : {"1", "2", "3"}) {
    const std::string key = std::string("# tracking_rms_rad_") + j + " = ";
    const std::size_t at = text.find(key);
    if (at == std::string::npos) {
      ADD_FAILURE() << csv << " has no " << key;
      return 0.0;
    }
    worst = std::max(worst, std::strtod(text.c_str() + at + key.size(), nullptr));
  }
  return worst;
}

// The point of it all, as a user runs it on vcan in lock-step with the
// multibody robot: fit path1 (PSO, the default), load the model into the
// controller, and the pick-and-place tracks at least 5 times better (the
// worst joint's RMS, the controller's own measurement) than with the
// nominal feed-forward, at the same gains. The controller and the
// emulator end cleanly.
TEST(HostExcite, TheFittedModelAsFeedForwardTracksThePickAndPlaceFiveTimesBetter) {
  MultibodySession& s = multibody_session();
  ASSERT_EQ(s.excite_exit, 0) << s.told();
  const auto excite = [&](const std::string& trajectory, const std::string& csv) {
    hil::Child e = hil::Child::spawn({kBin + "/host_id", "excite", "--modbus", s.modbus,
                                      "--trajectory", trajectory, "--can", kIface, "-o", csv});
    const int code = e.wait(300s).value_or(-1);
    EXPECT_EQ(code, 0) << e.out() << e.err();
    return code == 0;
  };
  hil::Child fit = hil::Child::spawn(
      {kBin + "/host_id", "fit", s.dir + "/path1.csv", "--out", s.dir + "/fit.json", "--quiet"});
  ASSERT_EQ(fit.wait(300s).value_or(-1), 0) << fit.err();
  ASSERT_TRUE(excite("pick-and-place", s.dir + "/nominal.csv")) << s.told();
  hil::Child load =
      hil::Child::spawn({kBin + "/host_id", "model", "load", s.dir + "/fit.json", "--can", kIface});
  ASSERT_EQ(load.wait(60s).value_or(-1), 0) << load.err();
  // The last run as a script takes it: --json, nothing else on stdout.
  hil::Child last = hil::Child::spawn({kBin + "/host_id", "excite", "--modbus", s.modbus,
                                       "--trajectory", "pick-and-place", "--can", kIface, "-o",
                                       s.dir + "/model.csv", "--json", "--quiet"});
  ASSERT_EQ(last.wait(300s).value_or(-1), 0) << last.err() << s.told();
  const std::string summary = last.out();
  EXPECT_EQ(summary.rfind("{", 0), 0u) << summary;
  for (const char* key : {"\"finished\": true", "\"lost\": 0",
                          "\"tracking_rms_rad_1\": ", "\"trajectory\": \"pick-and-place\""}) {
    EXPECT_NE(summary.find(key), std::string::npos) << key << " in " << summary;
  }
  EXPECT_EQ(last.err().find("host_id excite: running"), std::string::npos) << last.err();
  const double nominal = worst_tracking_rms(s.dir + "/nominal.csv");
  const double model = worst_tracking_rms(s.dir + "/model.csv");
  std::cout << "pick-and-place, worst joint's RMS tracking error: nominal feed-forward " << nominal
            << " rad, identified model " << model << " rad (" << nominal / model << "x)\n";
  EXPECT_GE(nominal, 5.0 * model);
  EXPECT_EQ(s.fw.terminate(30s).value_or(-1), 0) << s.fw.err();
  EXPECT_NE(s.fw.err().find("tracking pick-and-place: rms_rad="), std::string::npos) << s.fw.err();
  EXPECT_EQ(s.emu.terminate(30s).value_or(-1), 0) << s.emu.err();
  // This robot's gearboxes are rigid: the emulator's `arm tracking` of
  // each run (path1, nominal, model) is the controller's own tracking.
  const std::vector<double> arm = worst_arm_tracking(s.emu.out());
  ASSERT_EQ(arm.size(), 3u) << s.emu.out();
  EXPECT_NEAR(arm[1], nominal, 0.02 * nominal);
  EXPECT_NEAR(arm[2], model, 0.02 * model);
}

// The number after `key` in `text` (the first such), NaN where none is.
double number_after(const std::string& text, const std::string& key) {
  const std::size_t at = text.find(key);
  return at == std::string::npos ? std::nan("")
                                 : std::strtod(text.c_str() + at + key.size(), nullptr);
}

// One pick-and-place on the multibody robot with the fitted model as the
// feed-forward, the collision detector on as it comes with it (its own
// thresholds, no key), and `inject` in the emulator; delta_fw's exit code,
// its words and the emulator's.
struct CollisionRun {
  int exit{-1};
  std::string fw, emu;
};
CollisionRun pick_and_place_with_detector(const std::string& model,
                                          const std::vector<std::string>& inject) {
  hil::Child emu = start_emulator(inject);
  hil::Child fw = hil::Child::spawn({kBin + "/delta_fw", "--can", kIface, "--lockstep", "--set",
                                     "feed_forward.store=", "--set", "feed_forward.model=" + model,
                                     "--run", "pick-and-place", "--exit-when-done"});
  CollisionRun r;
  r.exit = fw.wait(300s).value_or(-1);
  emu.terminate(30s);
  r.fw = fw.err() + fw.out();
  r.emu = emu.out() + emu.err();
  return r;
}

// Collision detection on vcan (docs/safety.md), with the model fitted from
// the recorded path1 and the thresholds it carries: a clean pick-and-place
// run reaches its end with no detection; a 10 N contact on the platform
// for 200 ms, in each of five directions, spread over three moments (2 s:
// holding; 3 s: at 2 rad/s; 5 s: accelerating at 5-7 rad/s^2), is
// detected within 10 ms of its onset (delta_fw's `collision` line against
// the emulator's `contact` line, both in seconds since the first SYNC; the
// controller ticks at 500 Hz), with fault 14 and exit code 3. Each
// direction at each moment, and two clean runs, are in one process in
// ChainCollision (tests/unit), which the VM would take minutes over.
TEST(HostExcite, ContactsWithTheRobotAreDetectedWithinTenMilliseconds) {
  MultibodySession& s = multibody_session();
  const std::string model = s.dir + "/fit.json";
  ASSERT_TRUE(std::ifstream(model).good()) << "the fitted model of the test before";
  const CollisionRun clean = pick_and_place_with_detector(model, {"--seed", "2"});
  EXPECT_EQ(clean.exit, 0) << clean.fw;
  EXPECT_EQ(clean.fw.find("collision pick-and-place"), std::string::npos) << clean.fw;
  EXPECT_NE(clean.fw.find("collision detection on: the model's thresholds (fit 0x"),
            std::string::npos)
      << clean.fw;
  double worst_ms = 0.0;
  for (const char* contact :
       {"1,0,0:200@2", "0,1,0:200@3", "-1,0,0:200@5", "0,-1,0:200@2", "0,0,-1:200@3"}) {
    SCOPED_TRACE(contact);
    const CollisionRun hit =
        pick_and_place_with_detector(model, {"--inject", std::string("contact:10:") + contact});
    EXPECT_EQ(hit.exit, 3) << hit.fw;
    EXPECT_NE(hit.fw.find("fault 14 (collision)"), std::string::npos) << hit.fw;
    const double contact_s = number_after(hit.emu, "contact: t_s=");
    const double detected_s = number_after(hit.fw, "collision pick-and-place: t_s=");
    const double ms = (detected_s - contact_s) * 1e3;
    std::cout << "contact 10 N " << contact << ": at " << contact_s << " s, detected at "
              << detected_s << " s: " << ms << " ms\n";
    EXPECT_GE(detected_s, contact_s) << hit.fw << hit.emu;
    EXPECT_LE(ms, 10.0 + 1e-6) << hit.fw << hit.emu;
    worst_ms = std::max(worst_ms, ms);
  }
  std::cout << "5 contacts of 10 N: detected within " << worst_ms << " ms at worst\n";
}

// A collision as the user's tools see it (the contact 6 s into the bus's
// time: inside the run, which excite starts once delta_fw is up): host_id
// excite stops with the
// controller's fault, names the detection (its COLLISION frames on the
// bus), keeps it in the partial log's metadata, and host_id status shows
// the detector and its last event over Modbus.
TEST(HostExcite, ACollisionIsInTheRecordedLogAndInTheStatus) {
  MultibodySession& s = multibody_session();
  const std::string model = s.dir + "/fit.json";
  ASSERT_TRUE(std::ifstream(model).good()) << "the fitted model of the test before";
  hil::Child emu = start_emulator({"--inject", "contact:10:1,0,0:200@6"});
  hil::Child fw = start_firmware_with_modbus(
      15027, {"--set", "feed_forward.store=", "--set", "feed_forward.model=" + model});
  hil::Child excite =
      hil::Child::spawn({kBin + "/host_id", "excite", "--modbus", "127.0.0.1:15027", "--trajectory",
                         "pick-and-place", "--can", kIface, "-o", s.dir + "/hit.csv"});
  ASSERT_EQ(excite.wait(300s).value_or(-1), 4)
      << excite.out() << excite.err() << stopped_and_told(fw, emu);
  const std::string said = excite.err();
  EXPECT_NE(said.find("the controller faulted: fault 14 (collision)"), std::string::npos) << said;
  EXPECT_NE(said.find("host_id excite: the controller detected a collision after the log's "
                      "sample at t = "),
            std::string::npos)
      << said;
  std::ifstream partial(s.dir + "/hit.partial.csv");
  const std::string text((std::istreambuf_iterator<char>(partial)),
                         std::istreambuf_iterator<char>());
  for (const char* key : {"# collision_t_s = ", "# collision_joint = ",
                          "# collision_residual_Nm = ", "# collision_threshold_Nm = "}) {
    EXPECT_NE(text.find(key), std::string::npos) << key;
  }
  hil::Child status =
      hil::Child::spawn({kBin + "/host_id", "status", "--modbus", "127.0.0.1:15027"});
  EXPECT_EQ(status.wait(30s).value_or(-1), 0) << status.err();
  EXPECT_NE(status.out().find("  collision  detector on; last of 1: joint "), std::string::npos)
      << status.out();
  fw.terminate(30s);
  emu.terminate(30s);
}

// The designed excitation end to end: host_id design writes a trajectory
// file, excite uploads it into the controller's custom trajectory
// registers over Modbus, the controller checks and runs it on the
// multibody robot, the recorder logs it, and the default model fits it.
TEST(HostExcite, ADesignedTrajectoryFileIsUploadedRunAndFitted) {
  const testsupport::ScratchDirectory scratch("delta_hil");
  const std::string& dir = scratch.path();
  // 40 PSO iterations: condition number 4.78 against 4.68 for the full
  // search, in a sixth of the time (the full one took about a minute in the
  // emulated VM); this test is about the chain, DesignTest about the search.
  hil::Child design = hil::Child::spawn(
      {kBin + "/host_id", "design", "-o", dir + "/designed.json", "--iterations", "40"});
  ASSERT_EQ(design.wait(120s).value_or(-1), 0) << design.out() << design.err();
  std::cout << design.out();
  hil::Child emu = start_emulator();
  hil::Child fw = start_firmware_with_modbus(15023);
  hil::Child excite = hil::Child::spawn({kBin + "/host_id", "excite", "--modbus", "127.0.0.1:15023",
                                         "--trajectory-file", dir + "/designed.json", "--can",
                                         kIface, "-o", dir + "/designed.csv"});
  ASSERT_EQ(excite.wait(300s).value_or(-1), 0)
      << excite.out() << excite.err() << stopped_and_told(fw, emu);
  std::cout << excite.out();
  const std::string said = excite.out() + excite.err();
  // At 500 Hz: 2 s approach, 1 s blend, two 5 s periods, 1 s blend, 0.4 s
  // hold, both ends (as path1, whose timing the design kept).
  EXPECT_EQ(sum_of_numbers(said, "recorded of ", true), 7201u) << said;
  EXPECT_NE(said.find("sent, 0 lost, "), std::string::npos) << said;
  std::ifstream log(dir + "/designed.csv");
  const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("# trajectory = custom"), std::string::npos);
  EXPECT_NE(text.find("# trajectory_file = " + dir + "/designed.json"), std::string::npos);
  EXPECT_EQ(fw.terminate(30s).value_or(-1), 0) << fw.err();
  EXPECT_EQ(emu.terminate(30s).value_or(-1), 0) << emu.err();
  expect_fit_stands_for_the_multibody_robot(dir + "/designed.csv", dir);
}

TEST(HostExcite, AFaultMidRunKeepsThePartialLogUnderItsOwnName) {
  const testsupport::ScratchDirectory scratch("delta_hil");
  const std::string& dir = scratch.path();
  // Node 2 reports an overcurrent 12 s of bus time after the emulator starts:
  // inside path1's 14.4 s run, which starts within the first seconds.
  hil::Child emu = start_emulator({"--inject", "overcurrent:2@12"});
  hil::Child fw = start_firmware_with_modbus(15022);
  hil::Child excite =
      hil::Child::spawn({kBin + "/host_id", "excite", "--modbus", "127.0.0.1:15022", "--trajectory",
                         "path1", "--can", kIface, "-o", dir + "/run.csv"});
  ASSERT_EQ(excite.wait(300s).value_or(-1), 4)
      << excite.out() << excite.err() << stopped_and_told(fw, emu);
  std::cout << excite.out() << excite.err();
  EXPECT_NE(excite.err().find("the controller faulted: fault 2 (drive fault)"), std::string::npos)
      << excite.err();
  EXPECT_NE(excite.err().find("the partial log is " + dir + "/run.partial.csv"), std::string::npos)
      << excite.err();
  // Which drive, and why, from the EMCYs on the bus; then the controller's.
  EXPECT_NE(excite.err().find("host_id excite: node 2 sent EMCY 0x2310 (continuous over-current), "
                              "error register 0x01, after the log's sample at t = "),
            std::string::npos)
      << excite.err();
  EXPECT_NE(excite.err().find("host_id excite: the controller (node 16) sent EMCY 0xFF02: fault 2 "
                              "(drive fault)"),
            std::string::npos)
      << excite.err();
  EXPECT_NE(excite.out().find("NOT finished"), std::string::npos) << excite.out();
  EXPECT_FALSE(std::ifstream(dir + "/run.csv").good()) << "no complete-looking log";
  std::ifstream partial(dir + "/run.partial.csv");
  ASSERT_TRUE(partial.good());
  std::size_t rows = 0;
  for (std::string line; std::getline(partial, line);) rows += !line.empty() && line[0] != '#';
  EXPECT_GT(rows, 1000u) << "several seconds were recorded before the fault";
  EXPECT_LT(rows, 7200u);
  EXPECT_EQ(fw.terminate(30s).value_or(-1), 3) << "it stays in fault: " << fw.err();
  emu.terminate(30s);
}

}  // namespace
