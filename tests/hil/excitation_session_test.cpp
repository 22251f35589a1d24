// One excitation session on a real vcan interface, with the real programs:
// delta_drive_emu on its lumped plant, delta_fw (the firmware's Linux port,
// in lock-step) running path1, and host_id record writing the log and the
// candump. The lumped plant's truth is what the lumped model contains
// exactly, so the fit is checked tightly against known values; the tests
// below share the session's frames, log and candump.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "bus_observer.hpp"
#include "child_process.hpp"
#include "delta/can/cia402.hpp"
#include "delta/can/protocol.hpp"
#include "delta/can/sdo.hpp"
#include "delta/can/socketcan.hpp"
#include "fit_checks.hpp"
#include "pipeline_programs.hpp"
#include "recorded_log.hpp"
#include "scratch_directory.hpp"

namespace {

namespace p = delta::can::protocol;
namespace cia = delta::can::cia402;
using delta::can::Frame;
using hil::BusObserver;
using hil::expect_every_record_accounted_for;
using hil::expect_fit_matches_truth;
using hil::kBin;
using hil::kIface;
using hil::kSource;
using hil::start_emulator;
using hil::start_path1_firmware;
using hil::sum_of_numbers;
using hil::u16;
using namespace std::chrono_literals;

// The excitation session's folder: DELTA_HIL_SESSION_DIR where ctest sets
// it, so that its candump and log outlive the VM for the independent tools'
// check (tests/hil/CMakeLists.txt, check_candump.py), emptied of an earlier
// session's files first; else a scratch folder of this process's.
std::string session_dir() {
  const char* given = std::getenv("DELTA_HIL_SESSION_DIR");
  if (given == nullptr || *given == '\0') return testsupport::process_scratch("delta_hil").path();
  std::filesystem::create_directories(given);
  for (const char* name : {"session.log", "path1.csv"}) {
    std::filesystem::remove(std::filesystem::path(given) / name);
  }
  return given;
}

// --- one excitation session, shared by the tests below --------------------

struct Session {
  std::string dir;
  std::vector<Frame> frames;
  int fw_exit{-1};
  int record_exit{-1};
  int emu_exit{-1};
  std::string fw_err;
  std::string record_out;
  std::string emu_err;
};

Session* g_session = nullptr;

class ExcitationSession : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    g_session = new Session;
    Session& s = *g_session;
    s.dir = session_dir();
    BusObserver bus;
    hil::Child emu = start_emulator({"--plant", "lumped"});
    hil::Child rec =
        hil::Child::spawn({kBin + "/host_id", "record", "--can", kIface, "-o", s.dir + "/path1.csv",
                           "--idle", "3", "--raw", s.dir + "/session.log"});
    ASSERT_TRUE(rec.wait_for_output("listening on", 30s)) << rec.err();
    hil::Child fw = start_path1_firmware();
    s.fw_exit = fw.wait(300s).value_or(-1);
    s.fw_err = fw.err();
    s.record_exit = rec.wait(60s).value_or(-1);
    s.record_out = rec.out() + rec.err();
    s.emu_exit = emu.terminate(30s).value_or(-1);
    s.emu_err = emu.err();
    s.frames = bus.stop();
  }
  static void TearDownTestSuite() {
    delete g_session;
    g_session = nullptr;
  }
};

TEST_F(ExcitationSession, TheProgramsFinishCleanly) {
  const Session& s = *g_session;
  EXPECT_EQ(s.fw_exit, 0) << s.fw_err << s.emu_err;
  EXPECT_NE(s.fw_err.find("delta_fw: running path1"), std::string::npos) << s.fw_err;
  EXPECT_EQ(s.record_exit, 0) << s.record_out;
  EXPECT_EQ(s.emu_exit, 0) << s.emu_err;
  std::cout << s.fw_err << s.record_out << s.emu_err;
}

// The first NMT command of each kind to all nodes: enter pre-operational
// and start (frames.size() where none came).
struct NmtCommands {
  std::size_t preop;
  std::size_t start;
};

NmtCommands first_nmt_commands(const std::vector<Frame>& frames) {
  NmtCommands nmt{frames.size(), frames.size()};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    if (f.id != 0 || f.dlc != 2) continue;
    if (f.data[0] == p::kNmtEnterPreOperational && f.data[1] == 0 && nmt.preop == frames.size())
      nmt.preop = i;
    if (f.data[0] == p::kNmtStart && f.data[1] == 0 && nmt.start == frames.size()) nmt.start = i;
  }
  return nmt;
}

// The SDO exchange with the node between the two NMT commands: every
// object answered, none aborted. Nine objects, and the PDOs: 14 mapping
// writes and TPDO2 off, as the generic profile's plan has it
// (docs/protocol.md).
void expect_sdo_configuration(const std::vector<Frame>& frames, const NmtCommands& nmt,
                              std::uint8_t node) {
  std::map<std::uint32_t, int> answered;  // index << 8 | sub
  int requests = 0;
  for (std::size_t i = nmt.preop; i < nmt.start; ++i) {
    const Frame& f = frames[i];
    if (f.id == p::cob_id(p::kSdoRx, node)) ++requests;
    if (f.id != p::cob_id(p::kSdoTx, node)) continue;
    const auto r = delta::can::sdo::parse_response(f.data);
    EXPECT_NE(r.kind, delta::can::sdo::ResponseKind::kAborted) << std::hex << r.index;
    ++answered[(std::uint32_t{r.index} << 8) | r.subindex];
  }
  EXPECT_EQ(requests, 9 + 15);
  for (std::uint32_t key :
       {0x100000u, 0x101801u, 0x607500u, 0x607600u, 0x608F01u, 0x606000u, 0x100600u, 0x101700u,
        0x101601u, 0x160001u, 0x160002u, 0x160003u, 0x1A0001u, 0x1A0002u, 0x1A0003u, 0x180101u}) {
    EXPECT_EQ(answered[key], 1) << std::hex << key;
  }
  for (std::uint32_t key : {0x140001u, 0x180001u, 0x160000u, 0x1A0000u}) {
    EXPECT_EQ(answered[key], 2) << std::hex << key;  // off and on; 0 and the count
  }
  EXPECT_EQ(answered[0x1A0101u], 0);  // no velocity PDO: its mapping is left alone
}

// CiA 402 after the start: shutdown, switch on, enable operation, in that
// order, and the drive reports operation enabled; at the end it is
// disabled again (controlword 0, switch on disabled).
void expect_cia402_enable_then_disable(const std::vector<Frame>& frames, const NmtCommands& nmt,
                                       std::uint8_t node) {
  std::vector<std::uint16_t> controlwords;
  bool enabled_seen = false;
  cia::State last_state = cia::State::kNotReadyToSwitchOn;
  std::uint16_t last_cw = 0xFFFF;
  for (std::size_t i = nmt.start; i < frames.size(); ++i) {
    const Frame& f = frames[i];
    if (f.id == p::cob_id(p::kRpdo1, node)) {
      last_cw = u16(f);
      if (controlwords.empty() || controlwords.back() != last_cw) controlwords.push_back(last_cw);
    }
    if (f.id == p::cob_id(p::kTpdo1, node)) {
      last_state = cia::decode_statusword(u16(f));
      enabled_seen = enabled_seen || last_state == cia::State::kOperationEnabled;
    }
  }
  const std::vector<std::uint16_t> expected{0x0000, cia::kShutdown, cia::kSwitchOn,
                                            cia::kEnableOperation, 0x0000};
  EXPECT_EQ(controlwords, expected);
  EXPECT_TRUE(enabled_seen);
  EXPECT_EQ(last_cw, 0x0000);
  EXPECT_EQ(last_state, cia::State::kSwitchOnDisabled);
}

TEST_F(ExcitationSession, BringUpIsNmtSdoConfigurationThenCia402Enable) {
  const auto& frames = g_session->frames;
  // NMT: pre-operational for all, later start for all.
  const NmtCommands nmt = first_nmt_commands(frames);
  ASSERT_LT(nmt.preop, nmt.start);
  ASSERT_LT(nmt.start, frames.size());
  for (std::uint8_t node = 1; node <= 3; ++node) {
    SCOPED_TRACE("node " + std::to_string(node));
    expect_sdo_configuration(frames, nmt, node);
    expect_cia402_enable_then_disable(frames, nmt, node);
  }
}

TEST_F(ExcitationSession, TheRecordedLogIsCompleteAndTheFitMatchesTheEmulatorsTruth) {
  const Session& s = *g_session;
  ASSERT_EQ(s.record_exit, 0) << s.record_out;
  // path1 at 500 Hz: 2 s approach, 1 s blend, 2 periods of 5 s, 1 s blend, 0.4 s hold.
  expect_every_record_accounted_for(s.record_out, sum_of_numbers(s.record_out, " samples (", false),
                                    7201);
  expect_fit_matches_truth(s.dir + "/path1.csv", s.dir);
}

// A minimal DBC reader, independent of common/can/protocol.hpp: messages
// (BO_) and their signals (SG_), little-endian as this bus uses.
struct DbcSignal {
  std::string name;
  unsigned start{0};
  unsigned length{0};
  bool is_signed{false};
  double factor{1};
};
struct DbcMessage {
  std::string name;
  unsigned dlc{0};
  std::vector<DbcSignal> signals;
};

std::map<std::uint32_t, DbcMessage> read_dbc(const std::string& path) {
  std::ifstream in(path);
  std::map<std::uint32_t, DbcMessage> messages;
  DbcMessage* current = nullptr;
  for (std::string line; std::getline(in, line);) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "BO_") {
      std::uint32_t id = 0;
      std::string name;
      unsigned dlc = 0;
      ls >> id >> name >> dlc;
      name.pop_back();  // ':'
      current = &messages[id];
      current->name = name;
      current->dlc = dlc;
    } else if (tag == "SG_" && current != nullptr) {
      DbcSignal s;
      std::string colon, layout, scale;
      ls >> s.name >> colon >> layout >> scale;
      // start|length@1+  (factor,offset)
      std::sscanf(layout.c_str(), "%u|%u", &s.start, &s.length);
      EXPECT_NE(layout.find("@1"), std::string::npos) << "big-endian signal " << s.name;
      s.is_signed = layout.back() == '-';
      std::sscanf(scale.c_str(), "(%lf", &s.factor);
      current->signals.push_back(s);
    } else if (tag.empty()) {
      current = nullptr;
    }
  }
  return messages;
}

double decode(const std::array<std::uint8_t, 8>& d, const DbcSignal& s) {
  std::uint64_t u = 0;
  for (unsigned i = 0; i < 8; ++i) u |= std::uint64_t{d[i]} << (8 * i);
  u = (u >> s.start) & (s.length == 64 ? ~0ull : ((1ull << s.length) - 1));
  std::int64_t v = static_cast<std::int64_t>(u);
  if (s.is_signed && (u >> (s.length - 1)) & 1) v -= std::int64_t{1} << s.length;
  return static_cast<double>(v) * s.factor;
}

TEST_F(ExcitationSession, TheCandumpOfTheSessionDecodesWithTheDbc) {
  const Session& s = *g_session;
  const auto dbc = read_dbc(kSource + "/docs/delta.dbc");
  ASSERT_GE(dbc.size(), 20u);
  // candump -L lines: (sec.usec) iface ID#DATA
  std::ifstream in(s.dir + "/session.log");
  std::map<std::string, int> per_message;
  std::map<std::uint64_t, std::array<double, 3>> q_by_seq;
  std::uint64_t lines = 0;
  for (std::string line; std::getline(in, line);) {
    ++lines;
    const auto hash = line.find('#');
    const auto space = line.rfind(' ', hash);
    ASSERT_NE(hash, std::string::npos) << line;
    const std::string id_text = line.substr(space + 1, hash - space - 1);
    const std::string data_text = line.substr(hash + 1);
    ASSERT_EQ(id_text.size(), 3u) << "only standard frames expected: " << line;
    const auto id = static_cast<std::uint32_t>(std::stoul(id_text, nullptr, 16));
    const auto it = dbc.find(id);
    ASSERT_NE(it, dbc.end()) << "no DBC message for " << line;
    ASSERT_EQ(data_text.size(), 2 * it->second.dlc) << line;
    std::array<std::uint8_t, 8> data{};
    for (unsigned i = 0; i < it->second.dlc; ++i) {
      data[i] = static_cast<std::uint8_t>(std::stoul(data_text.substr(2 * i, 2), nullptr, 16));
    }
    ++per_message[it->second.name];
    if (it->second.name == "LOG_A") {
      const auto& sig = it->second.signals;
      q_by_seq[static_cast<std::uint64_t>(decode(data, sig[0]))] = {decode(data, sig[1]),
                                                                    decode(data, sig[2]), 0};
    }
  }
  EXPECT_GT(lines, 50000u);
  for (const char* name :
       {"NMT", "SYNC", "TPDO1_1", "TPDO1_2", "TPDO1_3", "RPDO1_1", "SDO_RX_2", "SDO_TX_3",
        "HEARTBEAT_1", "LOG_A", "LOG_B", "LOG_C", "CONTROLLER_HEARTBEAT"}) {
    EXPECT_GT(per_message[name], 0) << name;
  }
  EXPECT_EQ(per_message["LOG_A"], per_message["LOG_C"]);
  // The decoded angles equal the recorded log's (first rows, seq = row).
  std::ifstream log(s.dir + "/path1.csv");
  std::string row;
  while (std::getline(log, row) && row[0] == '#') {
  }
  int compared = 0;
  while (std::getline(log, row) && compared < 500) {
    double seq = 0, t = 0, q1 = 0, q2 = 0;
    ASSERT_EQ(std::sscanf(row.c_str(), "%lf,%lf,%lf,%lf", &seq, &t, &q1, &q2), 4) << row;
    const auto it = q_by_seq.find(static_cast<std::uint64_t>(seq));
    ASSERT_NE(it, q_by_seq.end());
    EXPECT_DOUBLE_EQ(it->second[0], q1);
    EXPECT_DOUBLE_EQ(it->second[1], q2);
    ++compared;
  }
  EXPECT_EQ(compared, 500);
}

}  // namespace
