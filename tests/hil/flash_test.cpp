// Flashing the controller over CAN on vcan (docs/flashing.md), with the real
// programs: delta_boot supervising delta_fw against the emulated drives,
// and host_id flash. Each test starts from a fresh state folder holding the
// build's delta_fw.img.
#include <gtest/gtest.h>
#include <signal.h>

#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <tuple>
#include <vector>

#include "child_process.hpp"
#include "scratch_directory.hpp"
#include "vcan_interface.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const std::string kIface = hil::vcan_interface();
const std::string kBin = DELTA_BIN_DIR;
const std::string kVersion = DELTA_VERSION_TEXT;
const std::string kNextVersion = DELTA_NEXT_VERSION_TEXT;

using hil::ToolRun;

ToolRun host_id(std::vector<std::string> args) {
  args.insert(args.begin(), kBin + "/host_id");
  return hil::run_tool(args, 300s);
}

std::string read_text(const std::string& object) {
  const ToolRun r = host_id({"sdo", "read", object, "--node", "16", "--can", kIface});
  return r.code == 0 ? r.out : "error: " + r.err;
}

std::vector<char> bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::vector<char>& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// A small image whose program is a script that runs `program` (a build of
// delta_fw) with delta_boot's arguments: it starts, confirms and reports
// its version as that build does, for the tests whose point is not the
// transfer of a whole build (which takes most of a minute in the VM).
// `padding_bytes` of comment after the script make the transfer longer.
std::string wrapper_image(const std::string& dir, const std::string& name,
                          const std::string& program, const std::string& version,
                          std::size_t padding_bytes = 0) {
  const std::string script = dir + "/" + name + ".sh";
  {
    std::ofstream out(script);
    out << "#!/bin/sh\nexec " << program << " \"$@\"\n";
    for (std::size_t i = 0; i < padding_bytes / 64; ++i) out << '#' << std::string(62, 'x') << '\n';
  }
  const std::string image = dir + "/" + name + ".img";
  const ToolRun made = host_id({"image", "make", script, "-o", image, "--version", version});
  EXPECT_EQ(made.code, 0) << made.err;
  return image;
}

// The emulator, and delta_boot running delta_fw (lock-step) from a fresh
// state folder; `extra` goes to delta_boot, `program` to delta_fw.
class Flashing : public ::testing::Test {
 protected:
  void SetUp() override { fs::create_directory(dir_ + "/state"); }
  void TearDown() override {
    if (boot_) boot_->terminate(60s);
    if (emu_) emu_->terminate(30s);
  }
  void start(const std::vector<std::string>& extra = {},
             const std::vector<std::string>& program = {}) {
    emu_.emplace(
        hil::Child::spawn({kBin + "/delta_drive_emu", "--can", kIface, "--plant", "lumped"}));
    ASSERT_TRUE(emu_->wait_for_output("ready on " + kIface, 30s)) << emu_->err();
    std::vector<std::string> with_install{"--install", install_};
    with_install.insert(with_install.end(), extra.begin(), extra.end());
    start_boot(with_install, program);
  }
  // delta_boot alone, on the state folder as it is.
  void start_boot(const std::vector<std::string>& extra,
                  const std::vector<std::string>& program = {}) {
    std::vector<std::string> argv{kBin + "/delta_boot", "--state-dir", dir_ + "/state"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    argv.insert(argv.end(), {"--", "--can", kIface, "--lockstep"});
    argv.insert(argv.end(), program.begin(), program.end());
    boot_.emplace(hil::Child::spawn(argv));
    ASSERT_TRUE(boot_->wait_for_output("delta_fw: ready", 60s)) << boot_->err();
  }
  // The log delta_boot and its program wrote so far.
  const std::string& log() {
    boot_->wait_for_output("\x01", 10ms);  // reads what is there
    return boot_->err();
  }
  std::string path(const std::string& name) const { return dir_ + "/" + name; }
  // Key pairs WHO.key and WHO.pub.
  void keygen(std::initializer_list<const char*> who) {
    for (const std::string w : who) {
      ASSERT_EQ(
          host_id({"image", "keygen", "--secret", path(w + ".key"), "--public", path(w + ".pub")})
              .code,
          0);
    }
  }
  // The build's delta_fw image, signed with `key`, is the one installed.
  void install_signed_with(const std::string& key) {
    ASSERT_EQ(host_id({"image", "sign", kBin + "/delta_fw.img", "--key", path(key), "-o",
                       path("installed.img")})
                  .code,
              0);
    install_ = path("installed.img");
  }

  const testsupport::ScratchDirectory scratch_{"delta_flash"};
  const std::string dir_ = scratch_.path();
  std::string install_ = kBin + "/delta_fw.img";
  std::optional<hil::Child> emu_;
  std::optional<hil::Child> boot_;
};

TEST_F(Flashing, ANewerBuildIsDownloadedStartedConfirmedAndReportsItsVersion) {
  start();
  EXPECT_EQ(read_text("0x100A"), kVersion + "\n");
  const ToolRun r = host_id({"flash", kBin + "/delta_fw_next.img", "--can", kIface});
  ASSERT_EQ(r.code, 0) << r.err << log();
  EXPECT_NE(r.out.find("runs version " + kNextVersion + " (was " + kVersion + "), confirmed"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(read_text("0x100A"), kNextVersion + "\n");
  // host_id hears the confirmation from the program; delta_boot, which the
  // program told, may write its line a moment later.
  EXPECT_TRUE(boot_->wait_for_output("delta_boot: confirmed slot 1 (version " + kNextVersion, 30s))
      << log();
  // The transfer's cost on a real 1 Mbit/s bus: an 8-byte standard frame
  // is 111 bit times without stuffing (44 + 64 + 3 interframe), 1 us each;
  // the node answers once per block of 127 segments.
  unsigned long bytes = 0;
  unsigned long frames = 0;
  const auto at = r.out.find("confirmed; ");
  ASSERT_NE(at, std::string::npos) << r.out;
  ASSERT_EQ(std::sscanf(r.out.c_str() + at, "confirmed; %lu bytes in %*f s, %*f kB/s, %lu frames",
                        &bytes, &frames),
            2)
      << r.out;
  const double bus_s = static_cast<double>(frames + frames / 127) * 111e-6;
  const double nominal_kB_s = static_cast<double>(bytes) / 1024.0 / bus_s;
  std::cout << "host_id flash: " << r.out << "at 1 Mbit/s: " << frames << " frames take " << bus_s
            << " s of bus time, " << nominal_kB_s << " kB/s\n";
  EXPECT_GE(nominal_kB_s, 40.0) << "CiA 302-3 block download's usual 40-55 kB/s";
  // Flashing the older build back needs --allow-downgrade; as a script
  // runs it, with --json --quiet: the outcome alone, no progress.
  const std::string older = wrapper_image(dir_, "older", kBin + "/delta_fw", kVersion);
  const ToolRun down = host_id({"flash", older, "--can", kIface});
  EXPECT_EQ(down.code, 5) << down.err;
  EXPECT_NE(down.err.find("older than the running " + kNextVersion), std::string::npos) << down.err;
  const ToolRun back =
      host_id({"flash", older, "--can", kIface, "--allow-downgrade", "--json", "--quiet"});
  ASSERT_EQ(back.code, 0) << back.err << log();
  EXPECT_NE(back.out.find("\"version\": \"" + kVersion + "\""), std::string::npos) << back.out;
  EXPECT_NE(back.out.find("\"was\": \"" + kNextVersion + "\""), std::string::npos) << back.out;
  EXPECT_EQ(back.err.find("kB/s"), std::string::npos) << back.err;
}

TEST_F(Flashing, ACorruptedImageIsRefusedWithCrcErrorAndTheOldProgramRunsOn) {
  start();
  std::vector<char> image =
      bytes_of(wrapper_image(dir_, "next", kBin + "/delta_fw_next", kNextVersion));
  image[image.size() - 2] ^= 0x01;  // in the program, after the header
  write_bytes(path("corrupted.img"), image);
  const ToolRun here = host_id({"flash", path("corrupted.img"), "--can", kIface});
  EXPECT_EQ(here.code, 5) << here.err;
  EXPECT_NE(here.err.find("program CRC-32 does not match"), std::string::npos) << here.err;
  const ToolRun forced = host_id({"flash", path("corrupted.img"), "--can", kIface, "--force"});
  EXPECT_EQ(forced.code, 3) << forced.err;
  EXPECT_NE(forced.err.find("0x08000020"), std::string::npos) << forced.err;
  EXPECT_NE(forced.err.find("flash status (0x1F57): data format error or CRC error"),
            std::string::npos)
      << forced.err;
  EXPECT_EQ(read_text("0x100A"), kVersion + "\n");
}

TEST_F(Flashing, AnImageForAnotherProductIsRefusedHereAndByTheController) {
  start();
  const ToolRun made = host_id({"image", "make", kBin + "/delta_fw_next", "-o", path("other.img"),
                                "--version", kNextVersion, "--product", "0x17"});
  ASSERT_EQ(made.code, 0) << made.err;
  const ToolRun here = host_id({"flash", path("other.img"), "--can", kIface});
  EXPECT_EQ(here.code, 5) << here.err;
  EXPECT_NE(here.err.find("product 0x00000017; node 16 is vendor 0x0000DE17, product 0x00000016"),
            std::string::npos)
      << here.err;
  EXPECT_EQ(log().find("staged"), std::string::npos) << "nothing was sent";
  const ToolRun forced = host_id({"flash", path("other.img"), "--can", kIface, "--force"});
  EXPECT_EQ(forced.code, 3) << forced.err;
  EXPECT_NE(forced.err.find("another vendor or product"), std::string::npos) << forced.err;
  EXPECT_EQ(read_text("0x100A"), kVersion + "\n");
}

TEST_F(Flashing, ASignedControllerRefusesUnsignedAndWronglySignedImages) {
  keygen({"ours", "theirs"});
  const std::string next = wrapper_image(dir_, "next", kBin + "/delta_fw_next", kNextVersion);
  ASSERT_EQ(
      host_id({"image", "sign", next, "--key", path("theirs.key"), "-o", path("theirs.img")}).code,
      0);
  install_signed_with("ours.key");  // the installed program is signed with our key too
  start({"--public-key", path("ours.pub")});
  const ToolRun unsigned_run = host_id({"flash", next, "--can", kIface});
  EXPECT_EQ(unsigned_run.code, 3) << unsigned_run.err;
  EXPECT_NE(unsigned_run.err.find("flash secured"), std::string::npos) << unsigned_run.err;
  EXPECT_NE(unsigned_run.err.find("image is not signed"), std::string::npos) << unsigned_run.err;
  const ToolRun theirs = host_id({"flash", path("theirs.img"), "--can", kIface});
  EXPECT_EQ(theirs.code, 3) << theirs.err;
  EXPECT_NE(theirs.err.find("signature"), std::string::npos) << theirs.err;
  ASSERT_EQ(
      host_id({"image", "sign", next, "--key", path("ours.key"), "-o", path("ours.img")}).code, 0);
  const ToolRun ours = host_id({"flash", path("ours.img"), "--can", kIface});
  EXPECT_EQ(ours.code, 0) << ours.err << log();
  EXPECT_EQ(read_text("0x100A"), kNextVersion + "\n");
}

// A key image (docs/security.md) replaces the installed key over the bus
// only when it is signed with it: signed with another key or unsigned, the
// controller refuses it as it arrives; signed with the installed key, the
// new key is installed, delta_fw restarts with it (0x2F00:3), the running
// program still runs, and from then on an image signed with the old key
// is refused and one signed with the new key is flashed.
TEST_F(Flashing, AKeyImageSignedWithTheInstalledKeyReplacesItOverTheBus) {
  keygen({"ours", "theirs", "next"});
  install_signed_with("ours.key");
  start({"--public-key", path("ours.pub")});
  ASSERT_EQ(
      host_id({"image", "key", path("next.pub"), "-o", path("key.img"), "--version", "1.0.0"}).code,
      0);
  const ToolRun unsigned_run = host_id({"flash", path("key.img"), "--can", kIface});
  EXPECT_EQ(unsigned_run.code, 3) << unsigned_run.err;
  EXPECT_NE(unsigned_run.err.find("image is not signed"), std::string::npos) << unsigned_run.err;
  ASSERT_EQ(host_id({"image", "sign", path("key.img"), "--key", path("theirs.key"), "-o",
                     path("key-theirs.img")})
                .code,
            0);
  const ToolRun theirs = host_id({"flash", path("key-theirs.img"), "--can", kIface});
  EXPECT_EQ(theirs.code, 3) << theirs.err;
  EXPECT_NE(theirs.err.find("signature"), std::string::npos) << theirs.err;
  ASSERT_EQ(host_id({"image", "sign", path("key.img"), "--key", path("ours.key")}).code, 0);
  const ToolRun ours = host_id({"flash", path("key.img"), "--can", kIface});
  ASSERT_EQ(ours.code, 0) << ours.err << log();
  const std::string next_key = bytes_of(path("next.pub")).size() >= 8
                                   ? std::string(bytes_of(path("next.pub")).data(), 8)
                                   : std::string();
  std::string upper = next_key;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  EXPECT_NE(ours.out.find("replaced its public key ("), std::string::npos) << ours.out;
  EXPECT_NE(ours.out.find(" by " + upper + "...)"), std::string::npos) << ours.out;
  EXPECT_NE(log().find("by a key image signed with the old key"), std::string::npos) << log();
  EXPECT_EQ(read_text("0x100A"), kVersion + "\n");  // the same program runs on
  const std::string next = wrapper_image(dir_, "next", kBin + "/delta_fw_next", kNextVersion);
  ASSERT_EQ(
      host_id({"image", "sign", next, "--key", path("ours.key"), "-o", path("old-key.img")}).code,
      0);
  const ToolRun old_key = host_id({"flash", path("old-key.img"), "--can", kIface});
  EXPECT_EQ(old_key.code, 3) << old_key.err;
  EXPECT_NE(old_key.err.find("signature"), std::string::npos) << old_key.err;
  ASSERT_EQ(
      host_id({"image", "sign", next, "--key", path("next.key"), "-o", path("new-key.img")}).code,
      0);
  const ToolRun new_key = host_id({"flash", path("new-key.img"), "--can", kIface});
  EXPECT_EQ(new_key.code, 0) << new_key.err << log();
  EXPECT_EQ(read_text("0x100A"), kNextVersion + "\n");
}

TEST_F(Flashing, AProgramThatNeverConfirmsIsRolledBackWithTheReason) {
  start({"--trial-timeout", "3"});
  {
    std::ofstream script(path("hang.sh"));
    script << "#!/bin/sh\nexec sleep 600\n";
  }
  const ToolRun made = host_id(
      {"image", "make", path("hang.sh"), "-o", path("hang.img"), "--version", kNextVersion});
  ASSERT_EQ(made.code, 0) << made.err;
  const ToolRun r =
      host_id({"flash", path("hang.img"), "--can", kIface, "--confirm-timeout", "60"});
  EXPECT_EQ(r.code, 7) << r.err;
  EXPECT_NE(r.err.find("rolled the new program back (reason 1"), std::string::npos) << r.err;
  EXPECT_NE(log().find("did not confirm within 3000 ms"), std::string::npos) << log();
  EXPECT_NE(log().find("rolled back from slot 1"), std::string::npos) << log();
  EXPECT_EQ(read_text("0x100A"), kVersion + "\n");
  EXPECT_EQ(read_text("0x2F00:2"), "1 (0x01)\n") << "no confirmation in time";
}

TEST_F(Flashing, ADownloadWhileATrajectoryRunsIsRefusedWithTheDeviceStateAbort) {
  start({}, {"--run", "path1"});
  ASSERT_TRUE(boot_->wait_for_output("delta_fw: running", 60s)) << log();
  const ToolRun r = host_id({"flash", kBin + "/delta_fw_next.img", "--can", kIface});
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("0x08000022"), std::string::npos) << r.err;
  EXPECT_EQ(log().find("delta_boot: staged"), std::string::npos);
}

TEST_F(Flashing, AFlashKilledPartWayLeavesTheOldProgramAndASecondAttemptSucceeds) {
  start();
  // Long enough a transfer (several seconds) to be killed part way.
  const std::string next =
      wrapper_image(dir_, "next", kBin + "/delta_fw_next", kNextVersion, 256 * 1024);
  hil::Child flash = hil::Child::spawn({kBin + "/host_id", "flash", next, "--can", kIface});
  ASSERT_TRUE(flash.wait_for_output(" kB/s", 120s)) << flash.err();
  kill(flash.pid(), SIGKILL);
  flash.wait(30s);
  EXPECT_EQ(log().find("delta_boot: staged"), std::string::npos);
  // The second attempt ends the transfer the node still holds (an SDO abort),
  // then starts over.
  const ToolRun again = host_id({"flash", next, "--can", kIface});
  EXPECT_EQ(again.code, 0) << again.err << log();
  EXPECT_NE(again.out.find("(was " + kVersion + ")"), std::string::npos) << "the old one ran on";
  EXPECT_EQ(read_text("0x100A"), kNextVersion + "\n");
}

// host_id flash killed at its last step, while it waits for the new
// program's confirmation: the controller needs it no more; the new program
// confirms itself and runs.
TEST_F(Flashing, AFlashKilledWhileItWaitsForTheConfirmationStillEndsConfirmed) {
  start();
  const std::string next = wrapper_image(dir_, "next", kBin + "/delta_fw_next", kNextVersion);
  hil::Child flash = hil::Child::spawn({kBin + "/host_id", "flash", next, "--can", kIface});
  ASSERT_TRUE(flash.wait_for_output("waiting for it to confirm", 120s)) << flash.err() << log();
  kill(flash.pid(), SIGKILL);
  EXPECT_EQ(flash.wait(30s).value_or(-1), 128 + SIGKILL);
  ASSERT_EQ(flash.out().find("confirmed"), std::string::npos) << "killed too late: " << flash.out();
  EXPECT_TRUE(boot_->wait_for_output("delta_boot: confirmed slot 1", 120s)) << log();
  EXPECT_EQ(read_text("0x100A"), kNextVersion + "\n");
}

// Power lost during the slot switch (the fault matrix's row): a staged
// program that never confirms is on trial when delta_boot and that program
// are killed (SIGKILL: no clean-up, as when the power goes). delta_boot
// started again on the same state folder rolls back with reason 4, and the
// old delta_fw runs and reports the reason over CAN (0x2F00:2).
TEST_F(Flashing, PowerLostDuringTheTrialRollsBackOnRestartWithReasonFour) {
  start({"--trial-timeout", "120"});
  {
    std::ofstream script(path("hang.sh"));
    script << "#!/bin/sh\nexec sleep 600\n";
  }
  ASSERT_EQ(
      host_id({"image", "make", path("hang.sh"), "-o", path("hang.img"), "--version", kNextVersion})
          .code,
      0);
  hil::Child flash = hil::Child::spawn(
      {kBin + "/host_id", "flash", path("hang.img"), "--can", kIface, "--confirm-timeout", "120"});
  ASSERT_TRUE(boot_->wait_for_output("on trial, pid ", 120s)) << log() << flash.err();
  const std::string said = log();
  const int program_pid = std::stoi(said.substr(said.find("on trial, pid ") + 14));
  kill(boot_->pid(), SIGKILL);
  kill(program_pid, SIGKILL);
  EXPECT_EQ(boot_->wait(30s).value_or(-1), 128 + SIGKILL);
  start_boot({"--trial-timeout", "120"});
  EXPECT_NE(log().find("the controller restarted during the trial"), std::string::npos) << log();
  EXPECT_EQ(read_text("0x100A"), kVersion + "\n");
  EXPECT_EQ(read_text("0x2F00:2"), "4 (0x04)\n") << "the reason: power lost during the trial";
  const int flash_exit = flash.wait(180s).value_or(-1);
  std::cout << flash.out() << flash.err();
  EXPECT_EQ(flash_exit, 7);
  EXPECT_NE(flash.err().find("rolled the new program back (reason 4"), std::string::npos)
      << flash.err();
}

}  // namespace
