// The firmware's Linux port's configuration file (read_port_config): keys
// over the defaults, a trajectory file, a fitted model, EDS files, and the
// errors that name file, line, column and key; and the drives' unit
// conversions.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>

#include "delta/modbus/register_map.hpp"
#include "delta/trajectory_file.hpp"
#include "fw/controller.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/drive_units.hpp"
#include "fw_linux/trajectories.hpp"
#include "in_process_rig.hpp"
#include "port_test_support.hpp"

namespace fw_linux {
namespace {

using port_test::scratch_file;
using port_test::write_temp;

std::string config_error(const std::string& text) {
  try {
    read_port_config(write_temp(text));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(PortConfigTest, ReadsKeysOverTheDefaults) {
  const PortConfig c = read_port_config(write_temp(
      "# a robot\nperiod_us = 2500\nmode = lockstep\nvelocity_pdo = true\n"
      "joint2.node = 7   # comment\njoint3.inverted = yes\ngains.kp_Nm_per_rad = 45.5\n"));
  EXPECT_EQ(c.period_us, 2500u);
  EXPECT_EQ(c.mode, CycleMode::kLockStep);
  EXPECT_TRUE(c.velocity_pdo);
  EXPECT_EQ(c.joints[1].node, 7);
  EXPECT_TRUE(c.joints[2].model.inverted);
  EXPECT_DOUBLE_EQ(c.kp_Nm_per_rad, 45.5);
  EXPECT_EQ(c.joints[0].node, 1);  // default kept
}

// robot = FILE: the robot description gives the geometry, the gear
// ratios, the limits it has and the nominal feed-forward; a key also set
// in the configuration must agree, else both places are named.
TEST(PortConfigTest, TheRobotDescriptionIsTheOneSourceOfGeometryAndLimits) {
  std::ifstream in("docs/examples/robot.json");  // tests run in the repository
  std::string robot((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  robot.replace(robot.find("\"upper_arm_length_m\": 0.2"), 25, "\"upper_arm_length_m\": 0.22");
  robot.replace(robot.rfind('}'), 1, ", \"limits\": {\"min_rad\": -1.0, \"max_torque_Nm\": 40}}");
  for (std::size_t at = 0; (at = robot.find("\"gear_ratio\": 10", at)) != std::string::npos;)
    robot.replace(at, 16, "\"gear_ratio\": 12");
  const std::string file = scratch_file("robot.json");
  std::ofstream(file) << robot;
  const PortConfig c = read_port_config(write_temp("robot = " + file + "\n"));
  EXPECT_DOUBLE_EQ(c.geometry.upper_arm_length_m, 0.22);
  EXPECT_DOUBLE_EQ(c.geometry.forearm_length_m, 0.46);
  EXPECT_DOUBLE_EQ(c.min_rad, -1.0);
  EXPECT_DOUBLE_EQ(c.max_rad, 1.4);  // the file has none: the controller's default
  EXPECT_DOUBLE_EQ(c.max_torque_Nm, 40.0);
  EXPECT_DOUBLE_EQ(c.joints[2].model.gear_ratio, 12.0);
  EXPECT_NE(describe_robot(c).find("arms 0.22 and 0.46 m"), std::string::npos) << describe_robot(c);
  // The nominal feed-forward is the description's robot's: a longer arm
  // carries a third of the platform further out.
  const double a = 0.22;
  const delta::LumpedParameters p = delta::lumped_truth(*c.robot);
  const fw::ControllerConfig core = controller_config(c);
  EXPECT_NEAR(std::ldexp(core.feed_forward.nominal.arm_inertia_kg_m2.raw(), -19),
              p.arm_inertia_kg_m2[0] + p.platform_mass_kg * a * a / 3.0, 1e-5);
  // The same value in both places is taken; another is refused, naming both.
  EXPECT_EQ(config_error("robot = " + file + "\ngains.max_torque_Nm = 40\n"), "");
  const std::string e = config_error("robot = " + file + "\ngeometry.upper_arm_length_m = 0.2\n");
  EXPECT_NE(e.find(":2:31: geometry.upper_arm_length_m = 0.2, but the robot description " + file),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("has geometry.upper_arm_length_m = 0.22: give it in one place"),
            std::string::npos)
      << e;
  EXPECT_NE(config_error("robot = " + file + "\njoint2.gear_ratio = 10\n")
                .find("has joints[1].gear_ratio = 12"),
            std::string::npos);
  EXPECT_NE(config_error("robot = nowhere.json\n").find(":1:9: robot: nowhere.json"),
            std::string::npos)
      << config_error("robot = nowhere.json\n");
}

// trajectory_file fills the custom trajectory's registers: `--run custom`
// (and trajectory 3 over Modbus) runs the file's excitation.
TEST(PortConfigTest, ATrajectoryFileBecomesTheCustomTrajectory) {
  delta::BlendedFourierTrajectory t;
  ASSERT_TRUE(delta::make_fourier_excitation(delta::kDefaultGeometry, {0.0, 0.0, -0.42}, 4, 0.3,
                                             0.3, 9, t.fourier));
  t.blend_s = 0.5;
  t.periods = 3;
  const std::string file = scratch_file("t.json");
  std::ofstream(file) << delta::format_trajectory(t, "");
  const PortConfig c = read_port_config(write_temp("trajectory_file = " + file + "\n"));
  ASSERT_EQ(c.custom_block.size(), delta::modbus::kCustomCount);
  const auto custom = named_trajectory("custom", c);
  ASSERT_TRUE(custom.has_value());
  const fw::TrajectoryConfig direct = fourier_config(t, c.period_us);
  EXPECT_EQ(custom->blend_ticks, direct.blend_ticks);
  EXPECT_EQ(custom->fourier.periods, 3u);
  EXPECT_EQ(custom->fourier.harmonics, 4);
  EXPECT_EQ(custom->fourier.base_frequency_mHz, 300u);
  EXPECT_LE(std::abs(custom->fourier.sin_amplitude_rad[2][3].raw() -
                     direct.fourier.sin_amplitude_rad[2][3].raw()),
            1);
  // No file: no custom trajectory, said so.
  try {
    named_trajectory("custom", PortConfig{});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("custom: no custom trajectory (set trajectory_file"),
              std::string::npos);
  }
  // A bad file: the configuration's line and the file's key.
  std::ofstream(file) << "{\"format\": \"delta-trajectory/1\"}";
  EXPECT_NE(config_error("trajectory_file = " + file + "\n")
                .find(":1:19: trajectory_file: " + file + ": kind: missing"),
            std::string::npos)
      << config_error("trajectory_file = " + file + "\n");
}

// A Fourier preset is its generator's excitation for the configured
// geometry however often it is built, and another geometry gets its own.
TEST(PortConfigTest, AFourierPresetIsItsGeneratorsExcitationForTheGeometry) {
  const delta::FourierPreset* fp = delta::fourier_preset("path1");
  ASSERT_NE(fp, nullptr);
  PortConfig other;
  other.geometry.forearm_length_m = 0.5;
  for (const PortConfig& c : {PortConfig{}, other, PortConfig{}, other}) {
    delta::BlendedFourierTrajectory t;
    ASSERT_TRUE(delta::make_fourier_excitation(c.geometry, fp->centre_m, fp->harmonics,
                                               fp->base_frequency_hz, fp->amplitude_rad, fp->seed,
                                               t.fourier));
    t.blend_s = c.blend_s;
    t.periods = fp->periods;
    const fw::TrajectoryConfig direct = fourier_config(t, c.period_us, 700);
    const auto built = named_trajectory("path1", c, TrajectoryParams{700, 0});
    ASSERT_TRUE(built.has_value());
    EXPECT_EQ(built->fourier.q0_rad, direct.fourier.q0_rad);
    EXPECT_EQ(built->fourier.sin_amplitude_rad, direct.fourier.sin_amplitude_rad);
    EXPECT_EQ(built->fourier.cos_amplitude_rad, direct.fourier.cos_amplitude_rad);
    EXPECT_EQ(built->fourier.periods, direct.fourier.periods);
    EXPECT_EQ(built->blend_ticks, direct.blend_ticks);
  }
  EXPECT_NE(named_trajectory("path1", other)->fourier.q0_rad,
            named_trajectory("path1", PortConfig{})->fourier.q0_rad);
}

// A saved fit as host_id writes it (the parts the controller reads).
std::string result_json(const std::string& model, const std::string& geometry,
                        const std::string& parameters) {
  return "{\"format\": \"host_id-result/1\", \"model\": {\"name\": \"" + model +
         "\", \"per_joint\": false, \"offsets\": false, \"coulomb_smoothing_rad_s\": 0.01}, "
         "\"geometry\": " +
         geometry + ", \"parameters\": {" + parameters + "}}";
}

const char* const kDefaultGeometryJson =
    "{\"upper_arm_length_m\": 0.2, \"forearm_length_m\": 0.46, \"base_radius_m\": 0.1, "
    "\"platform_radius_m\": 0.035}";
const char* const kLumpedParameters =
    "\"arm_inertia\": 0.0072, \"arm_gravity_moment\": 0.441, \"platform_mass\": 0.4, "
    "\"viscous_friction_1\": 0.02, \"viscous_friction_2\": 0.025, \"viscous_friction_3\": 0.018, "
    "\"coulomb_friction_1\": 0.06, \"coulomb_friction_2\": 0.05, \"coulomb_friction_3\": 0.07";

// feed_forward.model: a saved fit becomes the model feed-forward (the mode
// follows unless feed_forward says otherwise); one fitted for another
// robot, one without physical parameters or with a value the controller
// cannot hold is refused, naming what and why.
TEST(PortConfigTest, AFittedModelBecomesTheFeedForward) {
  const std::string file = scratch_file("result.json");
  std::ofstream(file) << result_json("lumped", kDefaultGeometryJson, kLumpedParameters);
  const PortConfig c = read_port_config(write_temp("feed_forward.model = " + file + "\n"));
  EXPECT_EQ(c.feed_forward, fw::FeedForwardMode::kModel);
  ASSERT_TRUE(c.feed_forward_model.has_value());
  EXPECT_DOUBLE_EQ(c.feed_forward_model->parameters.platform_inertial_mass_kg, 0.4);
  EXPECT_DOUBLE_EQ(c.feed_forward_model->parameters.arm_inertia_kg_m2[2], 0.0072);
  const fw::ControllerConfig core = controller_config(c);
  EXPECT_EQ(core.feed_forward.mode, fw::FeedForwardMode::kModel);
  EXPECT_EQ(core.feed_forward.model.parameters.kind, delta::fx::ModelKind::kLumped);
  EXPECT_EQ(core.feed_forward.model.geometry, core.geometry);
  EXPECT_EQ(core.feed_forward.model.parameters.coulomb_friction_Nm[1].raw(),
            delta::fx::Q12_19::from(0.05).raw());
  const PortConfig kept =
      read_port_config(write_temp("feed_forward = nominal\nfeed_forward.model = " + file + "\n"));
  EXPECT_EQ(kept.feed_forward, fw::FeedForwardMode::kNominal);

  EXPECT_NE(config_error("feed_forward = model\n")
                .find("feed_forward = model needs feed_forward"
                      ".model = RESULT.json"),
            std::string::npos);
  EXPECT_NE(config_error("feed_forward = on\n").find("feed_forward must be off, nominal or model"),
            std::string::npos);
  // Another robot: both geometries named.
  std::ofstream(file) << result_json(
      "lumped",
      "{\"upper_arm_length_m\": 0.25, \"forearm_length_m\": 0.46, \"base_radius_m\": 0.1, "
      "\"platform_radius_m\": 0.035}",
      kLumpedParameters);
  const std::string other = config_error("feed_forward.model = " + file + "\n");
  EXPECT_NE(other.find("feed_forward.model " + file +
                       ": fitted for another robot: the model's "
                       "geometry is upper arm 0.25 m"),
            std::string::npos)
      << other;
  EXPECT_NE(other.find("the controller's is upper arm 0.2 m"), std::string::npos) << other;
  // paper14 has no physical parameters; a missing parameter; a negative mass.
  std::ofstream(file) << result_json("paper14", kDefaultGeometryJson, "\"beta1\": 0.01");
  EXPECT_NE(config_error("feed_forward.model = " + file + "\n")
                .find(":1:22: feed_forward.model: " + file + ": model 'paper14' has no physical"),
            std::string::npos)
      << config_error("feed_forward.model = " + file + "\n");
  std::ofstream(file) << result_json("lumped", kDefaultGeometryJson, "\"arm_inertia\": 0.0072");
  EXPECT_NE(config_error("feed_forward.model = " + file + "\n")
                .find(file + ": parameter 'arm_gravity_moment' is missing"),
            std::string::npos)
      << config_error("feed_forward.model = " + file + "\n");
  std::string negative = kLumpedParameters;
  negative.replace(negative.find("\"platform_mass\": 0.4"), 20, "\"platform_mass\": -0.4");
  std::ofstream(file) << result_json("lumped", kDefaultGeometryJson, negative);
  EXPECT_NE(config_error("feed_forward.model = " + file + "\n")
                .find("parameter platform_mass = -0.4 kg is outside what the controller "
                      "holds: 0 to 128 kg"),
            std::string::npos)
      << config_error("feed_forward.model = " + file + "\n");
}

// A fit with cogging terms loads, but the controller has none: the
// feed-forward line says it leaves the cogging out.
TEST(PortConfigTest, AFitsCoggingIsNamedAsLeftOut) {
  const std::string file = scratch_file("cogging.json");
  std::string json = result_json(
      "lumped", kDefaultGeometryJson,
      std::string(kLumpedParameters) + ", \"cogging_sin_1\": 0.03, \"cogging_cos_1\": -0.04");
  const std::string smoothing = "\"coulomb_smoothing_rad_s\": 0.01";
  json.insert(json.find(smoothing) + smoothing.size(), ", \"cogging_periods_per_rev\": [60, 0, 0]");
  std::ofstream(file) << json;
  const PortConfig c = read_port_config(write_temp("feed_forward.model = " + file + "\n"));
  ASSERT_TRUE(c.feed_forward_model.has_value());
  EXPECT_NEAR(c.feed_forward_model->cogging_amplitude_Nm[0], 0.05, 1e-12);
  const std::string line = describe_feed_forward(c);
  EXPECT_NE(line.find("note: the controller's feed-forward leaves out the fit's cogging (joint 1: "
                      "0.05 N m at 60 periods per revolution)"),
            std::string::npos)
      << line;
  // Without the terms, nothing is said.
  std::ofstream(file) << result_json("lumped", kDefaultGeometryJson, kLumpedParameters);
  EXPECT_EQ(
      describe_feed_forward(read_port_config(write_temp("feed_forward.model = " + file + "\n")))
          .find("leaves out"),
      std::string::npos);
}

TEST(PortConfigTest, ErrorsNameFileLineColumnAndKey) {
  EXPECT_NE(config_error("period_us = 2ms\n")
                .find("port_test.conf:1:13: period_us needs a decimal number, got '2ms'"),
            std::string::npos)
      << config_error("period_us = 2ms\n");
  EXPECT_NE(config_error("\n  bogus = 1\n").find(":2:3: unknown key 'bogus'"), std::string::npos);
  EXPECT_NE(config_error("mode = fast\n").find(":1:8: mode must be"), std::string::npos);
  EXPECT_NE(config_error("stop_s = 1\nstop_s = 2\n").find(":2:1: 'stop_s' is set twice"),
            std::string::npos);
  EXPECT_NE(config_error("period_us 2000\n").find(":1:1: expected 'key = value'"),
            std::string::npos);
  EXPECT_NE(config_error("period_us = 3000\n").find("must divide one second"), std::string::npos);
  EXPECT_NE(config_error("joint1.node = 2\n").find("joint2.node = 2 is also joint1's node"),
            std::string::npos);
  EXPECT_NE(
      config_error("controller_heartbeat_timeout_ms = 50\n")
          .find("controller_heartbeat_timeout_ms must be 0 (off) or longer than heartbeat_ms"),
      std::string::npos);
  // At 5 Hz the heartbeat leaves every 200 ms, whatever heartbeat_ms: a
  // 150 ms timeout would fault every drive (found on vcan once the drives
  // really watched the controller).
  EXPECT_NE(config_error("period_us = 200000\n")
                .find("the controller's heartbeat comes every 200 ms (heartbeat_ms = 50 in whole "
                      "cycles of period_us = 200000), and controller_heartbeat_timeout_ms = 150"),
            std::string::npos)
      << config_error("period_us = 200000\n");
  EXPECT_NE(config_error("gains.max_torque_Nm = 5000\n").find("does not fit Q12.19"),
            std::string::npos)
      << config_error("gains.max_torque_Nm = 5000\n");
  try {
    read_port_config("/nonexistent/robot.conf");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/robot.conf: cannot open"),
              std::string::npos);
  }
}

// The emulated drive's EDS (docs/eds/), edited: `from` replaced by `to`,
// written to a file of this process's own.
std::string edited_eds(const std::string& from, const std::string& to, const std::string& name) {
  std::ifstream in(DELTA_EDS_DIR "/delta_drive_emu.eds");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  const std::string path = scratch_file(name);
  std::ofstream(path) << text;
  return path;
}

TEST(PortConfigTest, ADrivesEdsGivesTheIdentityToExpect) {
  const std::string eds = DELTA_EDS_DIR "/delta_drive_emu.eds";
  const PortConfig c =
      read_port_config(write_temp("joint2.eds = " + eds + "\njoint2.serial = 65538\n"));
  const DriveIdentity& id = c.joints[1].identity;
  EXPECT_EQ(id.vendor_id, 0x0000DE17u);
  EXPECT_EQ(id.product_code, 0x00000402u);
  EXPECT_EQ(id.revision, 0x00010000u);
  EXPECT_EQ(id.serial, 65538u);
  EXPECT_EQ(id.source, "joint2.eds = " + eds);
  EXPECT_FALSE(c.joints[0].identity.vendor_id.has_value());  // no EDS: any identity
}

TEST(PortConfigTest, AnEdsThatCannotServeTheBringUpIsRefusedWithItsReason) {
  // An object of a type the file does not define, which the bring-up
  // writes: the joint's key and the EDS's own file:line.
  std::string path = edited_eds(
      "DataType=0x0006\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n\n[1019]",
      "DataType=0x0066\nAccessType=rw\nDefaultValue=0\nPDOMapping=0\n\n[1019]", "bad_type.eds");
  std::string e = config_error("joint1.eds = " + path + "\n");
  EXPECT_NE(e.find("joint1.eds (" + path + ":"), std::string::npos) << e;
  EXPECT_NE(e.find("): 0x1017:00 (producer heartbeat time) is of data type 0x0066, which this "
                   "file does not define: the controller supervises the drive by its heartbeat"),
            std::string::npos)
      << e;
  // An object the bring-up writes, read-only in this drive.
  path =
      edited_eds("DataType=0x0002\nAccessType=rw", "DataType=0x0002\nAccessType=ro", "ro_mode.eds");
  e = config_error("joint3.eds = " + path + "\n");
  EXPECT_NE(e.find("joint3.eds (" + path +
                   ":358): 0x6060:00 (modes of operation) is not "
                   "writable: the controller cannot select a torque mode"),
            std::string::npos)
      << e;
  // A PDO's object that the drive cannot map: refused only where it is used.
  path = edited_eds("DataType=0x0004\nAccessType=ro\nPDOMapping=1\n\n[6071]",
                    "DataType=0x0004\nAccessType=ro\nPDOMapping=0\n\n[6071]", "unmapped.eds");
  EXPECT_EQ(config_error("joint1.eds = " + path + "\n"), "");
  e = config_error("joint1.eds = " + path + "\nvelocity_pdo = true\n");
  EXPECT_NE(e.find(": 0x606C:00 (velocity actual value) is not PDO-mappable: TPDO2 must carry it"),
            std::string::npos)
      << e;
  e = config_error("joint1.eds = /nonexistent/drive.eds\n");
  EXPECT_NE(e.find("joint1.eds: /nonexistent/drive.eds: cannot open"), std::string::npos) << e;
}

// sync_counter_overflow is CiA 301's 0x1019 (0 or 2..240), and a drive
// whose EDS cannot map the counter into TPDO3 is refused at load time.
TEST(PortConfigTest, ASyncCounterNeedsCiA301sRangeAndDrivesThatCanEchoIt) {
  const std::string eds = DELTA_EDS_DIR "/delta_drive_emu.eds";
  EXPECT_NE(config_error("sync_counter_overflow = 1\n")
                .find(":1:25: sync_counter_overflow must be 0 (no counter) or from 2 to 240"),
            std::string::npos);
  EXPECT_NE(config_error("sync_counter_overflow = 241\n")
                .find("sync_counter_overflow must be a whole number from 0 to 240, got '241'"),
            std::string::npos);
  EXPECT_EQ(read_port_config(write_temp("sync_counter_overflow = 240\njoint2.eds = " + eds + "\n"))
                .sync_counter_overflow,
            240);
  const std::string unmapped = edited_eds(
      "SYNC counter of the sample\nObjectType=0x7\n"
      "DataType=0x0005\nAccessType=ro\nDefaultValue=0\n"
      "PDOMapping=1",
      "SYNC counter of the sample\nObjectType=0x7\n"
      "DataType=0x0005\nAccessType=ro\nDefaultValue=0\n"
      "PDOMapping=0",
      "no_echo.eds");
  const std::string e = config_error("joint3.eds = " + unmapped + "\nsync_counter_overflow = 16\n");
  EXPECT_NE(e.find("joint3.eds (" + unmapped +
                   ":912): 0x2019:00 (SYNC counter of the sample) is not PDO-mappable: "
                   "sync_counter_overflow = 16 needs it in TPDO3"),
            std::string::npos)
      << e;
  // Without the counter the same drive is fine.
  EXPECT_EQ(config_error("joint3.eds = " + unmapped + "\n"), "");
}

// Values that parse but cannot be represented are refused at load time,
// with the key, the value and the range (fuzzing findings of #19): each of
// these was accepted, and each broke the controller in its own way.
TEST(PortConfigTest, ValuesThatCannotBeRepresentedAreRefusedWithTheirRange) {
  const auto refuses = [](const std::string& text, const std::string& message) {
    const std::string e = config_error(text);
    EXPECT_NE(e.find(message), std::string::npos) << text << " gave: " << e;
  };
  // strtod took hexadecimal and a doubled sign.
  refuses("approach_s = 0x.2\n", ":1:14: approach_s needs a decimal number, got '0x.2'");
  refuses("blend_s = +-1\n", ":1:11: blend_s needs a decimal number, got '+-1'");
  refuses("limits.max_rad = inf\n", "limits.max_rad needs a decimal number, got 'inf'");
  // The tick count wrapped (2 521 180 408 ticks) or became 0.
  refuses("stop_s = 11111115\n", ":1:10: stop_s = 11111115 s is out of range (0, 3600] s");
  refuses("stop_s = 1e31\n", ":1:10: stop_s = 1e31 s is out of range (0, 3600] s");
  refuses("approach_s = 1e31\n", "approach_s = 1e31 s is out of range (0, 3600] s");
  // The torque constant rounded to 0 in Q7.24: every torque of the joint 0.
  refuses("joint1.rated_current_A = 24294967296\n",
          ":1:26: joint1.rated_current_A = 24294967296 A is out of range (0, 1000] A");
  refuses("joint1.rated_current_A = 900\njoint1.rated_torque_Nm = 0.001\n",
          "joint1.rated_torque_Nm / joint1.rated_current_A = 1.11111e-06 N m/A is below what its "
          "Q7.24 format keeps to 0.1 %");
  // The zero overflowed int64 in the angle conversion (or, beyond 8 rad,
  // saturated every angle).
  refuses("joint1.zero_rad = 34359738367\n",
          ":1:19: joint1.zero_rad = 34359738367 rad is out of range [-3.14159, 3.14159] rad");
  refuses("joint3.zero_rad = -8\n", "joint3.zero_rad = -8 rad is out of range");
  // What is representable still reads.
  EXPECT_EQ(config_error("stop_s = 3600\njoint1.zero_rad = -3.14\napproach_s = +2.5\n"), "");
}

TEST(DriveUnitsTest, ConversionsAgreeWithTheDriveModel) {
  delta::DriveModel m;  // 10:1, 17 bits, 2 A, 0.2 N m
  const DriveUnits u(m, 2000, 200);
  const double counts_per_rad = m.counts_per_rev * m.gear_ratio / (2 * std::numbers::pi);
  for (double q : {-1.1, -0.3, 0.0, 0.45, 1.3}) {
    const auto counts = static_cast<std::int32_t>(std::lround(q * counts_per_rad));
    const double back = std::ldexp(u.joint_angle(counts).raw(), -28);
    EXPECT_NEAR(back, q, 1.0 / counts_per_rad);  // within a count
    EXPECT_NEAR(u.counts(u.joint_angle(counts)), counts, 1);
  }
  EXPECT_NEAR(std::ldexp(u.joint_velocity(std::llround(2.0 * counts_per_rad)).raw(), -21), 2.0,
              1e-6);
  EXPECT_EQ(u.current(1000).raw(), 2 << 19);     // 1000 per mille of 2 A
  EXPECT_EQ(u.current(-250).raw(), -(1 << 18));  // -0.5 A
  // 1 A at k_t 0.1 N m/A is 0.1 N m: 500 per mille of 0.2 N m.
  EXPECT_EQ(u.target_torque(delta::fx::Q12_19::from(1.0)), 500);
  EXPECT_EQ(u.target_torque(delta::fx::Q12_19::from(-200.0)), INT16_MIN);  // saturated
  delta::DriveModel inv = m;
  inv.inverted = true;
  inv.joint_zero_rad = 0.5;
  const DriveUnits ui(inv, 2000, 200);
  EXPECT_NEAR(std::ldexp(ui.joint_angle(-1000).raw(), -28), 0.5 + 1000 / counts_per_rad, 1e-8);
}

}  // namespace
}  // namespace fw_linux
