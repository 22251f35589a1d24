// Each drive's bring-up planned from its EDS and the configuration
// (fw_linux/drive_plan.hpp), on the test corpus of drive descriptions
// (tests/data/drives/, each modelled on a drive family), and
// `delta_fw --check-config`.
#include "fw_linux/drive_plan.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>

#include "../../support/scratch_directory.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {
namespace {

std::string drive(const std::string& name) {
  return std::string(DELTA_DRIVES_DIR) + "/" + name;
}

// A configuration from `key = value` lines; with `problems`, every problem
// is kept there.
PortConfig config(const std::string& text, std::vector<std::string>* problems = nullptr) {
  const std::string path = testsupport::process_scratch("drive_plan_test").file("drives.conf");
  std::ofstream(path) << text;
  return read_port_config(path, problems);
}

std::vector<std::string> problems_of(const std::string& text) {
  std::vector<std::string> problems;
  (void)config(text, &problems);
  return problems;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& l : lines) text += l + "\n";
  return text;
}

bool writes(const DrivePlan& plan, std::uint16_t index, std::uint8_t subindex,
            std::uint32_t value) {
  for (const SdoAction& a : plan.actions) {
    if (a.size != 0 && a.object.index == index && a.object.subindex == subindex && a.value == value)
      return true;
  }
  return false;
}

bool touches(const DrivePlan& plan, std::uint16_t index) {
  for (const SdoAction& a : plan.actions) {
    if (a.object.index == index) return true;
  }
  return false;
}

// The EPOS4: CST, torque feedback (no 0x6078), 0x6076 a setting whose
// default is 0, no 0x608F: served once the configuration gives the rated
// torque and the encoder resolution; TPDO1's transmission type written.
TEST(DrivePlanTest, AnEpos4LikeDriveServesWithTheValuesItsEdsCannotGive) {
  const auto missing = problems_of("joint1.eds = " + drive("epos4.eds") + "\n");
  ASSERT_EQ(missing.size(), 2u) << joined(missing);
  EXPECT_NE(
      missing[0].find("joint1.rated_torque_Nm is not set, and joint1.eds (" + drive("epos4.eds") +
                      ":1196) gives 0x6076:00 (motor rated torque) a default of 0"),
      std::string::npos)
      << missing[0];
  EXPECT_NE(missing[1].find("no object 0x608F:01 (position encoder resolution), and "
                            "joint1.counts_per_rev is not set"),
            std::string::npos)
      << missing[1];

  const PortConfig c = config("joint1.eds = " + drive("epos4.eds") +
                              "\njoint1.rated_torque_Nm = 0.128\njoint1.counts_per_rev = 4096\n");
  const DrivePlan plan = plan_drives(c).drives[0];
  EXPECT_EQ(plan.mode, 10);
  EXPECT_EQ(plan.feedback, Feedback::kTorque);
  EXPECT_EQ(plan.sample.layout.entries[2], 0x60770010u);
  EXPECT_TRUE(writes(plan, 0x1800, 2, 1));     // TPDO1 on every SYNC (default 255)
  EXPECT_TRUE(writes(plan, 0x1006, 0, 2000));  // the cycle period
  EXPECT_TRUE(writes(plan, 0x6072, 0, 6945));  // 8 N m at the joint: 0.889 N m at the motor
  // TPDO COB-IDs keep the EDS's bit 30 (no remote request): off, then on.
  EXPECT_TRUE(writes(plan, 0x1800, 1, 0xC0000181));
  EXPECT_TRUE(writes(plan, 0x1800, 1, 0x40000181));
  EXPECT_TRUE(writes(plan, 0x1803, 1, 0xC0000481));  // TPDO4 off
  EXPECT_TRUE(writes(plan, 0x6060, 0, 10));
  EXPECT_FALSE(touches(plan, 0x3000));  // the manufacturer DEFTYPE object
  EXPECT_FALSE(touches(plan, 0x608F));
  EXPECT_EQ(plan.rated_torque_mNm, 0u);  // read from 0x6076 at bring-up, checked against 128
}

// The EPOS2 has no torque mode and no target torque: refused, naming both.
TEST(DrivePlanTest, ADriveWithoutATorqueModeIsRefusedNamingWhatItLacks) {
  const auto p = problems_of("joint2.eds = " + drive("epos2.eds") +
                             "\njoint2.rated_current_A = 2\njoint2.rated_torque_Nm = 0.2\n"
                             "joint2.counts_per_rev = 2000\n");
  const std::string text = joined(p);
  ASSERT_EQ(p.size(), 2u) << text;
  EXPECT_NE(text.find("joint2.eds (" + drive("epos2.eds") +
                      "): no object 0x6071:00 (target torque): the drive cannot take a torque "
                      "command"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find(":1190): 0x6502:00 (supported drive modes) is 0x00000065: neither cyclic "
                      "synchronous torque (bit 9) nor profile torque (bit 3)"),
            std::string::npos)
      << text;
}

// The Trinamic-like module: profile torque with a warning, torques in mA,
// 0x6072 defaults to 0, and no cycle-period object.
TEST(DrivePlanTest, ADriveWithProfileTorqueOnlyIsUsedWithAWarning) {
  const std::string eds = "joint3.eds = " + drive("tmcm_bldc.eds") + "\njoint3.torque_unit = mA\n";
  const auto p = problems_of(eds);
  ASSERT_EQ(p.size(), 1u) << joined(p);
  EXPECT_NE(p[0].find("0x6072:00 (max torque) defaults to 0: the drive would give no torque"),
            std::string::npos)
      << p[0];
  const PortConfig c = config(eds + "joint3.rated_torque_Nm = 0.4\n");
  const DrivePlan plan = plan_drives(c).drives[2];
  EXPECT_EQ(plan.mode, 4);
  EXPECT_EQ(plan.torque_unit, TorqueUnit::kMilliamp);
  EXPECT_NE(joined(plan.warnings).find("profile torque (mode 4) is not synchronous"),
            std::string::npos);
  EXPECT_NE(joined(plan.warnings).find("not told the cycle period"), std::string::npos);
  EXPECT_FALSE(touches(plan, 0x1006));
  EXPECT_TRUE(touches(plan, 0x6072));
}

// A DCF: its ParameterValue (0x6075 = 2000 mA) is the configuration's
// rated current; its NodeID must be the joint's node.
TEST(DrivePlanTest, ADcfGivesItsCommissionedValuesAndNode) {
  const std::string dcf =
      "joint2.eds = " + drive("nanotec_pd4c.dcf") + "\njoint2.rated_torque_Nm = 0.5\n";
  const PortConfig c = config(dcf);
  EXPECT_DOUBLE_EQ(c.joints[1].model.rated_current_A, 2.0);
  const DrivePlan plan = plan_drives(c).drives[1];
  EXPECT_TRUE(writes(plan, 0x6060, 0, 10));
  EXPECT_EQ(plan.rated_torque_mNm, 500u);  // no 0x6076: the configured value
  const auto p =
      problems_of("joint1.eds = " + drive("nanotec_pd4c.dcf") + "\njoint1.rated_torque_Nm = 0.5\n");
  ASSERT_EQ(p.size(), 1u) << joined(p);
  EXPECT_NE(p[0].find("is a DCF commissioned for node 2, but joint1.node = 1"), std::string::npos)
      << p[0];
}

// Read-only mappings: their defaults are used as they are, and the PDOs
// are decoded by them; a configured value the EDS contradicts is refused.
TEST(DrivePlanTest, AFixedMappingIsUsedAsItIsAndAContradictionIsNamed) {
  const PortConfig c = config("joint1.eds = " + drive("fixed_mapping.eds") + "\n");
  EXPECT_DOUBLE_EQ(c.joints[0].model.rated_torque_Nm, 1.27);  // the EDS's 0x6076
  const DrivePlan plan = plan_drives(c).drives[0];
  EXPECT_FALSE(plan.rpdo.mapping_written);
  EXPECT_FALSE(plan.sample.mapping_written);
  EXPECT_EQ(plan.rpdo.layout.bytes(), 4u);
  EXPECT_EQ(plan.sample.layout.offset_of({0x6077, 0}), 6);
  EXPECT_FALSE(touches(plan, 0x1600));
  EXPECT_FALSE(touches(plan, 0x1A00));
  EXPECT_TRUE(writes(plan, 0x1800, 2, 1));
  const auto p = problems_of("joint1.eds = " + drive("fixed_mapping.eds") +
                             "\njoint1.rated_torque_Nm = 1.0\n");
  ASSERT_EQ(p.size(), 1u) << joined(p);
  EXPECT_NE(p[0].find("0x6076:00 (motor rated torque) is 1270 in the EDS, but "
                      "joint1.rated_torque_Nm = 1"),
            std::string::npos)
      << p[0];
  // velocity_pdo needs TPDO2's fixed mapping to carry 0x606C: it does.
  EXPECT_TRUE(problems_of("joint1.eds = " + drive("fixed_mapping.eds") + "\nvelocity_pdo = true\n")
                  .empty());
}

// Where target torque and torque actual value are PDO-mappable only in
// fixed PDOs above PDO4 (fixed_pdo5.eds), those are searched and used: the
// control in RPDO5, the sample split over TPDO5 (statusword, torque) and
// TPDO1 (position). PDO5 has no predefined COB-ID: each takes that of a
// PDO turned off first (RPDO1's, TPDO4's).
TEST(DrivePlanTest, FixedPdosAbovePdo1AreSearchedAndASampleSplitOverTwo) {
  const std::string keys = "joint1.eds = " + drive("fixed_pdo5.eds") +
                           "\njoint1.rated_torque_Nm = 0.5\njoint1.counts_per_rev = 65536\n";
  const DrivePlans plans = plan_drives(config(keys));
  ASSERT_TRUE(plans.problems.empty()) << joined(plans.problems);
  const DrivePlan& plan = plans.drives[0];
  EXPECT_EQ(plan.feedback, Feedback::kTorque);
  EXPECT_EQ(plan.rpdo.number, 5u);
  EXPECT_EQ(plan.rpdo.cob_id, 0x201u);
  EXPECT_FALSE(plan.rpdo.mapping_written);
  EXPECT_EQ(plan.sample.number, 5u);
  EXPECT_EQ(plan.sample.cob_id, 0x481u);
  EXPECT_EQ(plan.sample.layout.offset_of({0x6077, 0}), 2);
  ASSERT_TRUE(plan.sample_rest.used);
  EXPECT_EQ(plan.sample_rest.number, 1u);
  EXPECT_EQ(plan.sample_rest.layout.count, 1u);
  EXPECT_EQ(plan.sample_rest.layout.offset_of({0x6064, 0}), 0);
  // RPDO1 off before RPDO5 takes its COB-ID; TPDO4 off before TPDO5.
  const auto step = [&](std::uint16_t index, std::uint32_t value) {
    for (std::size_t i = 0; i < plan.actions.size(); ++i) {
      if (plan.actions[i].object.index == index && plan.actions[i].object.subindex == 1 &&
          plan.actions[i].value == value)
        return static_cast<int>(i);
    }
    return -1;
  };
  ASSERT_GE(step(0x1400, 0x80000201), 0);
  EXPECT_LT(step(0x1400, 0x80000201), step(0x1404, 0x201));
  ASSERT_GE(step(0x1803, 0x80000481), 0);
  EXPECT_LT(step(0x1803, 0x80000481), step(0x1804, 0x481));
  EXPECT_TRUE(writes(plan, 0x1804, 2, 1));  // TPDO5 on every SYNC
  EXPECT_NE(describe_plan(plan).find("TPDO5:    COB-ID 0x481"), std::string::npos)
      << describe_plan(plan);
  // With the velocity in TPDO2 the split is the same.
  const DrivePlans with_velocity = plan_drives(config(keys + "velocity_pdo = true\n"));
  ASSERT_TRUE(with_velocity.problems.empty()) << joined(with_velocity.problems);
  EXPECT_EQ(with_velocity.drives[0].sample.number, 5u);
  EXPECT_EQ(with_velocity.drives[0].sample_rest.number, 1u);
  EXPECT_EQ(with_velocity.drives[0].velocity.number, 2u);
  // The SYNC counter's echo must follow the sample on the bus: a sample in
  // two TPDOs is refused with it, naming both and what to set.
  const auto echo = problems_of(keys + "sync_counter_overflow = 10\n");
  ASSERT_FALSE(echo.empty());
  EXPECT_NE(joined(echo).find("sync_counter_overflow = 10 needs the sample in one TPDO before "
                              "TPDO3's 0x381 on the bus, and this drive's comes in TPDO5 (0x481) "
                              "and TPDO1: set sync_counter_overflow = 0"),
            std::string::npos)
      << joined(echo);
}

// A drive without an object the PDOs need (the statusword) is refused,
// naming it: tmcm_bldc.eds with 0x6041 renamed 0x6042.
TEST(DrivePlanTest, AMissingStatuswordIsNamed) {
  std::ifstream in(drive("tmcm_bldc.eds"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* from : {"=0x6041\n", "[6041]"}) {
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text[at + (from[0] == '=' ? 6 : 4)] = '2';
  }
  const std::string path =
      testsupport::process_scratch("drive_plan_test").file("no_statusword.eds");
  std::ofstream(path) << text;
  const auto p = problems_of("joint1.eds = " + path + "\njoint1.torque_unit = mA\n" +
                             "joint1.rated_torque_Nm = 0.2\n");
  ASSERT_EQ(p.size(), 1u) << joined(p);
  EXPECT_EQ(p[0],
            "joint1.eds (" + path + "): no object 0x6041:00 (statusword): TPDO1 must carry it");
}

// Without an EDS the plan is the generic profile's (docs/drives.md):
// the rated values read from the drive, nothing else assumed away.
TEST(DrivePlanTest, WithoutAnEdsThePlanIsTheGenericProfiles) {
  const DrivePlan plan = plan_drives(PortConfig{}).drives[0];
  EXPECT_EQ(plan.mode, 10);
  EXPECT_EQ(plan.feedback, Feedback::kCurrent);
  EXPECT_TRUE(touches(plan, 0x6075));
  EXPECT_TRUE(touches(plan, 0x608F));
  EXPECT_FALSE(touches(plan, 0x1800) && writes(plan, 0x1800, 2, 1));
  EXPECT_TRUE(writes(plan, 0x1801, 1, 0x80000281));  // TPDO2 off without velocity_pdo
  EXPECT_EQ(plan.actions.size(), 24u);
}

// A drive at node 16, the controller's own: its TPDO1, EMCY, heartbeat and
// SDO COB-IDs are the controller's log, emergency, heartbeat and SDO
// server's. One problem names each collision and what to do.
TEST(DrivePlanTest, ADriveAtTheControllersNodeIsRefusedNamingEachCollision) {
  const auto p = problems_of("joint2.node = 16\n");
  ASSERT_EQ(p.size(), 1u) << joined(p);
  for (const char* expected :
       {"joint2.node = 16: COB-IDs collide on the bus: ",
        "joint2's EMCY 0x090 is also the controller's CONTROLLER_EMCY",
        "joint2's SDO response 0x590 is also the controller's SDO server (response)",
        "joint2's heartbeat 0x710 is also the controller's CONTROLLER_HEARTBEAT",
        "joint2's TPDO1 0x190 is also the controller's LOG_A",
        "node 16 is the controller's own: give the drive another node"}) {
    EXPECT_NE(p[0].find(expected), std::string::npos) << expected << "\n" << p[0];
  }
  EXPECT_TRUE(problems_of("joint2.node = 17\n").empty());
}

// A mistyped key names the key it most likely is (case or two edits
// apart); one far from every key just says it is unknown.
TEST(DrivePlanTest, AMistypedKeySuggestsTheKeyItMeant) {
  const auto p = problems_of("joint1.rated_torque_nm = 0.2\n");
  ASSERT_EQ(p.size(), 1u) << joined(p);
  EXPECT_NE(p[0].find("unknown key 'joint1.rated_torque_nm' (did you mean "
                      "'joint1.rated_torque_Nm'?)"),
            std::string::npos)
      << p[0];
  const auto far = problems_of("wobble = 1\n");
  ASSERT_EQ(far.size(), 1u) << joined(far);
  EXPECT_EQ(far[0].find("did you mean"), std::string::npos) << far[0];
}

// Problems in the order a user fixes them, each once: the same file on
// three joints gives one line naming the joints, and what keeps a drive
// from serving (no torque mode) comes before the values to set.
TEST(DrivePlanTest, ProblemsComeFatalFirstAndOnceForJointsThatShareThem) {
  const std::string epos2 = drive("epos2.eds"), epos4 = drive("epos4.eds");
  const auto shared = problems_of("joint1.eds = " + epos2 + "\njoint2.eds = " + epos2 +
                                  "\njoint3.eds = " + epos2 + "\n");
  ASSERT_FALSE(shared.empty());
  EXPECT_EQ(
      shared[0].rfind("joints 1, 2 and 3: jointN.eds (" + epos2 + "): no object 0x6071:00", 0), 0u)
      << joined(shared);
  for (const std::string& p : shared) EXPECT_EQ(p.find("joint1.eds"), std::string::npos) << p;
  const auto mixed = problems_of("joint1.eds = " + epos4 + "\njoint2.eds = " + epos2 + "\n");
  ASSERT_GE(mixed.size(), 3u) << joined(mixed);
  EXPECT_NE(mixed[0].find("no object 0x6071:00"), std::string::npos) << joined(mixed);
  EXPECT_NE(mixed.back().find("is not set"), std::string::npos) << joined(mixed);
}

// counts_per_rev against the EDS's 0x608F:01 (ipos.eds: 8000): agreeing is
// sound, contradicting is refused, as a contradicting rated value is.
TEST(DrivePlanTest, AnEncoderResolutionTheEdsContradictsIsNamed) {
  const std::string base = "joint1.eds = " + drive("ipos.eds") +
                           "\njoint1.rated_current_A = 2\njoint1.rated_torque_Nm = 0.2\n";
  EXPECT_TRUE(problems_of(base + "joint1.counts_per_rev = 8000\n").empty());
  const auto p = problems_of(base + "joint1.counts_per_rev = 4096\n");
  ASSERT_EQ(p.size(), 1u) << joined(p);
  EXPECT_NE(p[0].find("0x608F:01 (position encoder resolution) is 8000 in the EDS, but "
                      "joint1.counts_per_rev = 4096: which is the encoder's?"),
            std::string::npos)
      << p[0];
}

// A drive with 0x6071 and no 0x6076 (ipos.eds, tmcm_bldc.eds) gets a
// warning about its torque unit until the configuration names the unit.
TEST(DrivePlanTest, ATargetTorqueWithoutRatedTorqueAsksForTheUnit) {
  const std::string base = "joint1.eds = " + drive("ipos.eds") +
                           "\njoint1.rated_current_A = 2\njoint1.rated_torque_Nm = 0.2\n";
  const auto warned = plan_drives(config(base)).drives[0].warnings;
  EXPECT_NE(joined(warned).find("has 0x6071 (target torque) but no 0x6076 (motor rated torque)"),
            std::string::npos)
      << joined(warned);
  EXPECT_NE(joined(warned).find("set joint1.torque_unit"), std::string::npos);
  const auto quiet =
      plan_drives(config(base + "joint1.torque_unit = per_mille\n")).drives[0].warnings;
  EXPECT_EQ(joined(quiet).find("0x6076"), std::string::npos) << joined(quiet);
}

// gains.max_torque_Nm beyond what 0x6072 holds in per mille of the rated
// torque: written capped, with a warning giving the joint torque it caps at.
TEST(DrivePlanTest, AMaxTorqueThe6072CannotHoldIsCappedWithAWarning) {
  const std::string base = "joint1.eds = " + drive("fixed_mapping.eds") + "\n";
  const DrivePlan fits = plan_drives(config(base)).drives[0];
  EXPECT_EQ(joined(fits.warnings).find("capped"), std::string::npos) << joined(fits.warnings);
  const DrivePlan capped = plan_drives(config(base + "gains.max_torque_Nm = 400\n")).drives[0];
  EXPECT_TRUE(writes(capped, 0x6072, 0, 32767));
  EXPECT_NE(joined(capped.warnings).find("gains.max_torque_Nm = 400"), std::string::npos)
      << joined(capped.warnings);
  EXPECT_NE(joined(capped.warnings).find("capped at 32767 per mille"), std::string::npos);
}

// delta_fw --check-config: the plans and exit 0, or every problem and 2.
struct CommandRun {
  int status;
  std::string out;
};

CommandRun run_delta_fw(const std::string& arguments) {
  const std::string command = std::string(DELTA_FW_BINARY) + " " + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  CommandRun r{-1, ""};
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), static_cast<int>(buffer.size()), pipe) != nullptr)
    r.out += buffer.data();
  const int status = pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

TEST(CheckConfigTest, PrintsEachDrivesPlanOrEveryProblem) {
  const CommandRun ok =
      run_delta_fw("--check-config --set joint1.eds=" + drive("ipos.eds") +
                   " --set joint1.rated_current_A=3 --set joint1.rated_torque_Nm=0.3");
  EXPECT_EQ(ok.status, 0) << ok.out;
  EXPECT_NE(ok.out.find("joint1: node 1, " + drive("ipos.eds")), std::string::npos) << ok.out;
  EXPECT_NE(ok.out.find("TPDO1:    COB-ID 0x181, transmission type 1: 0x6041:00 (16 bits), "
                        "0x6064:00 (32 bits), 0x6078:00 (16 bits)"),
            std::string::npos)
      << ok.out;
  EXPECT_NE(ok.out.find("write 0x6060:00  modes of operation = 10, cyclic synchronous torque"),
            std::string::npos)
      << ok.out;
  EXPECT_NE(ok.out.find("The configuration is sound"), std::string::npos) << ok.out;
  EXPECT_NE(ok.out.find("bus load: 64.0 % of 1000 kbit/s"), std::string::npos) << ok.out;
  EXPECT_EQ(ok.out.find("warning: bus load"), std::string::npos) << ok.out;
  const CommandRun loaded = run_delta_fw("--check-config --set arm_encoders=true");
  EXPECT_EQ(loaded.status, 0) << loaded.out;
  EXPECT_NE(loaded.out.find("delta_fw --check-config: warning: bus load: 90.3 % of 1000 kbit/s"),
            std::string::npos)
      << loaded.out;

  const CommandRun bad = run_delta_fw("--check-config --set joint1.eds=" + drive("epos2.eds") +
                                      " --set joint2.eds=" + drive("epos4.eds") +
                                      " --set period_us=3000 --set joint3.node=x");
  EXPECT_EQ(bad.status, 2) << bad.out;
  for (const char* expected :
       {"--set joint3.node: joint3.node needs", "period_us = 3000 must divide one second",
        "joint1.eds (" DELTA_DRIVES_DIR "/epos2.eds): no object 0x6071:00 (target torque)",
        "joint2.rated_torque_Nm is not set"}) {
    EXPECT_NE(bad.out.find(expected), std::string::npos) << expected << "\n" << bad.out;
  }
  EXPECT_EQ(run_delta_fw("--check-config --config /nonexistent/delta.conf").status, 2);
}

}  // namespace
}  // namespace fw_linux

namespace fw_linux {
namespace {

// arm_encoders = true maps each drive's arm-side encoder, CiA 402's first
// additional position actual value (0x60E4:1), into TPDO4: on the emulated
// drive's EDS and the generic profile. A drive whose EDS cannot carry it
// (epos4.eds has no 0x60E4), or the SYNC counter, whose echo in TPDO3
// would come before TPDO4 on the bus, is refused, naming what to set.
TEST(DrivePlanTest, ArmEncodersAreMappedIntoTpdo4OrRefusedWithTheReason) {
  for (const std::string& eds :
       {std::string(), std::string(DELTA_EDS_DIR "/delta_drive_emu.eds")}) {
    const std::string keys = eds.empty() ? "" : "joint2.eds = " + eds + "\n";
    const DrivePlans plans = plan_drives(config(keys + "arm_encoders = true\n"));
    ASSERT_TRUE(plans.problems.empty()) << joined(plans.problems);
    const DrivePlan& plan = plans.drives[1];
    ASSERT_TRUE(plan.arm.used) << eds;
    EXPECT_EQ(plan.arm.number, 4u);
    EXPECT_EQ(plan.arm.cob_id, 0x482u);
    ASSERT_EQ(plan.arm.layout.count, 1u);
    EXPECT_EQ(plan.arm.layout.entries[0], 0x60E40120u);
    EXPECT_TRUE(writes(plan, 0x1A03, 1, 0x60E40120u)) << describe_plan(plan);
    EXPECT_NE(describe_plan(plan).find("TPDO4:    COB-ID 0x482"), std::string::npos)
        << describe_plan(plan);
  }
  EXPECT_FALSE(plan_drives(config("")).drives[0].arm.used);
  const auto no_object = problems_of("joint1.eds = " + drive("epos4.eds") +
                                     "\njoint1.rated_torque_Nm = 1\narm_encoders = true\n");
  EXPECT_NE(joined(no_object).find("0x60E4:01 (additional position actual value)"),
            std::string::npos)
      << joined(no_object);
  const auto echo = problems_of("arm_encoders = true\nsync_counter_overflow = 10\n");
  EXPECT_NE(joined(echo).find("joint1.arm_encoders = true puts the arm-side encoder in TPDO4 "
                              "(0x481), after the SYNC counter's echo in TPDO3: set "
                              "sync_counter_overflow = 0 or arm_encoders = false"),
            std::string::npos)
      << joined(echo);
}

}  // namespace
}  // namespace fw_linux
