#include "emu/emulator.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "delta/mujoco_plant.hpp"
#include "drive_objects.hpp"
#include "eds_objects.hpp"

namespace emu {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
namespace cia = delta::can::cia402;
using delta::can::Frame;

namespace {

constexpr double kTwoPi = 6.283185307179586;

const char* state_text(cia::State s) {
  switch (s) {
    case cia::State::kNotReadyToSwitchOn:
      return "not ready to switch on";
    case cia::State::kSwitchOnDisabled:
      return "switch on disabled";
    case cia::State::kReadyToSwitchOn:
      return "ready to switch on";
    case cia::State::kSwitchedOn:
      return "switched on";
    case cia::State::kOperationEnabled:
      return "operation enabled";
    case cia::State::kQuickStopActive:
      return "quick stop active";
    case cia::State::kFaultReactionActive:
      return "fault reaction active";
    case cia::State::kFault:
      return "fault";
  }
  return "?";
}

}  // namespace

FaultInjection parse_fault(const std::string& spec) {
  FaultInjection f;
  std::string body = spec;
  const auto at = spec.find('@');
  if (at != std::string::npos) {
    body = spec.substr(0, at);
    const std::string t = spec.substr(at + 1);
    char* end = nullptr;
    f.at_s = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0' || !(f.at_s >= 0)) {
      throw std::invalid_argument("fault '" + spec + "': time after '@' must be seconds >= 0");
    }
  }
  std::vector<std::string> parts;
  std::stringstream ss(body);
  for (std::string part; std::getline(ss, part, ':');) parts.push_back(part);
  if (parts.empty()) throw std::invalid_argument("fault '" + spec + "': no kind");
  const std::string& kind = parts[0];
  const bool needs_node = kind != "error-frame";
  if (kind == "heartbeat-drop") {
    f.kind = FaultKind::kHeartbeatDrop;
  } else if (kind == "silent") {
    f.kind = FaultKind::kSilent;
  } else if (kind == "error-frame") {
    f.kind = FaultKind::kErrorFrame;
  } else if (kind == "corrupt-pdo") {
    f.kind = FaultKind::kCorruptPdo;
  } else if (kind == "delay-pdo") {
    f.kind = FaultKind::kDelayPdo;
  } else if (kind == "overcurrent") {
    f.kind = FaultKind::kOvercurrent;
  } else {
    throw std::invalid_argument("fault '" + spec +
                                "': unknown kind (heartbeat-drop, silent, error-frame, "
                                "corrupt-pdo, delay-pdo, overcurrent)");
  }
  const std::size_t expected = needs_node ? (f.kind == FaultKind::kDelayPdo ? 3u : 2u) : 1u;
  if (parts.size() != expected) {
    throw std::invalid_argument("fault '" + spec + "': expected " +
                                (expected == 1   ? std::string("KIND@SECONDS")
                                 : expected == 2 ? std::string("KIND:NODE@SECONDS")
                                                 : std::string("KIND:NODE:MS@SECONDS")));
  }
  if (needs_node) {
    const int node = std::atoi(parts[1].c_str());
    if (node < 1 || node > 3 || parts[1] != std::to_string(node)) {
      throw std::invalid_argument("fault '" + spec + "': the node must be 1, 2 or 3");
    }
    f.node = static_cast<std::uint8_t>(node);
  }
  if (f.kind == FaultKind::kDelayPdo) {
    const long ms = std::atol(parts[2].c_str());
    if (ms <= 0 || ms > 10000 || parts[2] != std::to_string(ms)) {
      throw std::invalid_argument("fault '" + spec + "': the delay must be 1 to 10000 ms");
    }
    f.arg_ms = static_cast<std::uint32_t>(ms);
  }
  return f;
}

namespace {

std::unique_ptr<delta::Plant> make_plant(const EmulatorConfig& c) {
  if (c.plant == PlantKind::kMujoco) {
    return std::make_unique<delta::MujocoPlant>(
        c.robot, c.initial_q_rad,
        delta::MujocoSettings{delta::MujocoIntegrator::kEuler, delta::kMujocoCoarsestStep_s});
  }
  return std::make_unique<delta::LumpedPlant>(c.geometry, c.truth, c.initial_q_rad);
}

}  // namespace

Emulator::Emulator(const EmulatorConfig& config, Outbox out)
    : config_(config), out_(std::move(out)), plant_(make_plant(config)), rng_(config.seed) {
  for (unsigned j = 0; j < 3; ++j) {
    drives_[j].node = static_cast<std::uint8_t>(p::kFirstDriveNode + j);
    drives_[j].model = config.drives[j];
    drives_[j].pdos = product_.pdos;
    objects_[j] = std::make_unique<DriveTable>(DriveContext{*this, drives_[j]},
                                               DriveObjects::scalars(), DriveObjects::texts());
    sdo_servers_[j] = std::make_unique<sdo::Server>(*objects_[j]);
  }
}

Emulator::~Emulator() = default;

double Emulator::noise() {
  return rng_.normal();  // reproducible for a seed
}

void Emulator::send(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data,
                    std::uint32_t delay_us) {
  Frame f;
  f.id = id;
  f.dlc = dlc;
  f.data = data;
  if (p::function_code(id) == p::kEmcy.base_id && emergencies_.size() < kEmergenciesKept) {
    emergencies_.push_back({p::node_id(id),
                            static_cast<std::uint16_t>(p::unpack(data, p::kEmcyErrorCode)),
                            simulated_s()});
  }
  out_(f, delay_us);
}

void Emulator::send_heartbeat(Drive& d) {
  if (d.silent || d.heartbeat_dropped) return;
  std::array<std::uint8_t, 8> data{};
  data[0] = d.nmt;
  send(p::cob_id(p::kHeartbeat, d.node), 1, data);
}

void Emulator::boot() {
  for (Drive& d : drives_) {
    d.nmt = p::kNmtStatePreOperational;
    d.state = cia::drive_transition(cia::State::kNotReadyToSwitchOn, 0, 0);  // self-test done
    if (d.silent) continue;
    std::array<std::uint8_t, 8> data{};
    data[0] = p::kNmtStateBootUp;
    send(p::cob_id(p::kHeartbeat, d.node), 1, data);
  }
  trigger_faults();  // faults at 0 s apply from the start
}

namespace {
// Far longer than delta_fw's lock-step timeout (1 s: a drive that stays
// silent makes each lock-step cycle last that long) and than the stalls
// of a lock-step run in the emulated HIL VM (2.7 s seen): the controller
// is still alive then.
constexpr std::uint64_t kConsumerWallGraceUs = 5'000'000;
}  // namespace

void Emulator::on_wall_time(std::uint64_t now_us) {
  wall_us_ = now_us;
  for (unsigned j = 0; j < 3; ++j) {
    sdo_servers_[j]->tick(now_us);
    flush_sdo(j);
  }
  const std::uint64_t since_sync_us =
      last_sync_wall_us_ == 0 ? ~std::uint64_t{0} : now_us - last_sync_wall_us_;
  // While SYNCs come the consumers run on simulated time (handle_sync).
  // Once they stopped for kConsumerWallGraceUs, by the wall clock, with that
  // grace: a lock-step controller on a starved machine, or waiting for a
  // silent drive, is not taken for a dead one (a real drive has no grace).
  if (since_sync_us >= kConsumerWallGraceUs) {
    check_consumers([now_us](const Drive& d) {
      const std::uint64_t elapsed = now_us - d.consumed_wall_us;
      return elapsed > kConsumerWallGraceUs ? elapsed - kConsumerWallGraceUs : 0;
    });
  }
  if (since_sync_us < 100000) return;
  // The heartbeat by the wall clock once SYNCs stopped for 100 ms.
  for (Drive& d : drives_) {
    if (d.heartbeat_ms == 0) continue;
    if (now_us - d.last_heartbeat_wall_us >= std::uint64_t{d.heartbeat_ms} * 1000) {
      d.last_heartbeat_wall_us = now_us;
      send_heartbeat(d);
    }
  }
}

template <class Elapsed>
void Emulator::check_consumers(Elapsed elapsed_us) {
  for (Drive& d : drives_) {
    if (!d.consumer_armed || d.nmt != p::kNmtStateOperational) continue;
    if (elapsed_us(d) > std::uint64_t{od::consumer_heartbeat_timeout_ms(d.consumer)} * 1000) {
      d.consumer_armed = false;  // one event; the next heartbeat arms it again
      enter_fault(d, od::kEmcyHeartbeat);
    }
  }
}

void Emulator::handle_consumed_heartbeat(std::uint8_t node) {
  for (Drive& d : drives_) {
    if (od::consumer_heartbeat_timeout_ms(d.consumer) == 0 ||
        od::consumer_heartbeat_node(d.consumer) != node) {
      continue;
    }
    d.consumer_armed = true;
    d.consumed_sim_us = sim_us_;
    d.consumed_wall_us = wall_us_;
  }
}

void Emulator::on_frame(const Frame& f) {
  if (f.extended || f.remote) return;
  if (f.id == p::cob_id(p::kNmt, 0)) return handle_nmt(f);
  if (f.id == p::cob_id(p::kSync, 0)) return handle_sync(f);
  if (p::function_code(f.id) == p::kHeartbeat.base_id && f.dlc == 1) {
    return handle_consumed_heartbeat(p::node_id(f.id));
  }
  const std::uint8_t node = p::node_id(f.id);
  if (node < p::kFirstDriveNode || node >= p::kFirstDriveNode + p::kDriveCount) return;
  const unsigned j = node - p::kFirstDriveNode;
  Drive& d = drives_[j];
  if (d.silent) return;
  const std::uint32_t function = p::function_code(f.id);
  if (function == p::kSdoRx.base_id) {
    handle_sdo(j, f);
  } else if (function == p::kRpdo1.base_id) {
    handle_rpdo(j, f);
  }
}

void Emulator::handle_nmt(const Frame& f) {
  if (f.dlc != 2) return;
  const std::uint8_t command = f.data[0];
  const std::uint8_t target = f.data[1];
  for (Drive& d : drives_) {
    if (target != 0 && target != d.node) continue;
    switch (command) {
      case p::kNmtStart:
        d.nmt = p::kNmtStateOperational;
        break;
      case p::kNmtStop:
        d.nmt = p::kNmtStateStopped;
        break;
      case p::kNmtEnterPreOperational:
        d.nmt = p::kNmtStatePreOperational;
        break;
      case p::kNmtResetNode:
      case p::kNmtResetCommunication: {
        // CiA 301: both set the communication parameters (0x1000..0x1FFF)
        // to their power-on values; reset node the application's too, and
        // the drive restarts (power stage off).
        if (command == p::kNmtResetNode) reset_application(d);
        d.nmt = p::kNmtStatePreOperational;
        d.cycle_us = 0;
        d.heartbeat_ms = 0;
        d.consumer = 0;
        d.consumer_armed = false;
        d.sync_counter_overflow = 0;
        d.pdos = product_.pdos;
        d.last_sent = {};
        d.syncs_since = {};
        const auto j = static_cast<std::size_t>(&d - drives_.data());
        if (eds_objects_[j]) eds_objects_[j]->apply_defaults();
        if (!d.silent) {
          std::array<std::uint8_t, 8> data{};
          send(p::cob_id(p::kHeartbeat, d.node), 1, data);  // boot-up
        }
        break;
      }
      default:
        break;
    }
  }
}

// The application's parameters (0x6000..0x9FFF) at power-on, and the
// CiA 402 state machine after its self-test.
void Emulator::reset_application(Drive& d) {
  d.state = cia::drive_transition(cia::State::kNotReadyToSwitchOn, 0, 0);
  d.controlword = 0;
  d.target_torque_pm = 0;
  d.target_position = 0;
  d.mode = 0;
  d.max_current_pm = Drive{}.max_current_pm;
  d.max_torque_pm = Drive{}.max_torque_pm;
  d.torque_slope_pm_s = 0;
  d.ramped_A = 0.0;
}

// CiA 301: in NMT stopped a node answers NMT and error control only. A
// request that is not 8 bytes long is not an SDO request.
void Emulator::handle_sdo(unsigned j, const Frame& f) {
  if (f.dlc != 8 || drives_[j].nmt == p::kNmtStateStopped) return;
  sdo_servers_[j]->on_frame(f.data, wall_us_);
  flush_sdo(j);
}

void Emulator::flush_sdo(unsigned j) {
  sdo::Payload reply;
  while (sdo_servers_[j]->pending(reply)) {
    send(p::cob_id(p::kSdoTx, drives_[j].node), 8, reply);
    sdo_servers_[j]->sent(wall_us_);
  }
}

void Emulator::apply_controlword(Drive& d, std::uint16_t controlword) {
  const cia::State before = d.state;
  d.state = cia::drive_transition(d.state, controlword, d.controlword);
  d.controlword = controlword;
  if (before == cia::State::kFault && d.state != cia::State::kFault) {
    send(p::cob_id(p::kEmcy, d.node), 8, {});  // error reset
  }
}

// RPDO1 as mapped: each entry written to its object, in order (the
// controlword applies its transition). A frame shorter than the mapping is
// not processed: EMCY 0x8210 (CiA 301).
void Emulator::handle_rpdo(unsigned j, const Frame& f) {
  Drive& d = drives_[j];
  const PdoMapping& m = d.pdos[0];
  if (d.nmt != p::kNmtStateOperational || !m.valid) return;
  unsigned bytes = 0;
  for (unsigned i = 0; i < m.count; ++i) bytes += (m.entries[i] & 0xFF) / 8;
  if (f.dlc < bytes) {
    std::array<std::uint8_t, 8> data{};
    p::pack(data, p::kEmcyErrorCode, od::kEmcyPdoLength);
    send(p::cob_id(p::kEmcy, d.node), 8, data);
    return;
  }
  unsigned at = 0;
  for (unsigned i = 0; i < m.count; ++i) {
    const std::uint32_t e = m.entries[i];
    const unsigned n = (e & 0xFF) / 8;
    dictionary(j).write(static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>(e >> 8), 0,
                        std::span<const std::uint8_t>(f.data).subspan(at, n), true);
    at += n;
  }
}

// A TPDO as mapped, each entry read from its object, when its
// transmission type says this SYNC.
void Emulator::send_tpdo(unsigned j, unsigned pdo) {
  Drive& d = drives_[j];
  const PdoMapping& m = d.pdos[pdo];
  if (!m.valid || m.count == 0) return;
  std::array<std::uint8_t, 8> data{};
  unsigned at = 0;
  for (unsigned i = 0; i < m.count; ++i) {
    const std::uint32_t e = m.entries[i];
    const unsigned n = (e & 0xFF) / 8;
    dictionary(j).read(static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>(e >> 8), 0,
                       std::span<std::uint8_t>(data).subspan(at, n));
    at += n;
  }
  std::array<std::uint8_t, 9> payload{};
  std::copy(data.begin(), data.end(), payload.begin());
  payload[8] = static_cast<std::uint8_t>(at);
  if (!tpdo_due(d, pdo, payload)) return;
  auto dlc = static_cast<std::uint8_t>(at);
  if (pdo == 1 && d.corrupt_next) {
    dlc = 5;
    d.corrupt_next = false;
  }
  send(pdo_cob_id(d, pdo), dlc, data, d.delay_us);
}

// CiA 301's transmission types: 1 to 240 every that many SYNCs; 0 at the
// SYNC when the data changed; 254 and 255 event-driven, when the data
// changed (the emulated data change only at SYNCs); 252 and 253 on a
// remote request, which this bus does not use.
bool Emulator::tpdo_due(Drive& d, unsigned pdo, const std::array<std::uint8_t, 9>& payload) {
  const std::uint8_t type = d.pdos[pdo].transmission;
  bool due = false;
  if (type >= 1 && type <= 240) {
    due = ++d.syncs_since[pdo] >= type;
    if (due) d.syncs_since[pdo] = 0;
  } else if (type == 0 || type >= 254) {
    due = payload != d.last_sent[pdo];
  }
  if (due) d.last_sent[pdo] = payload;
  return due;
}

std::uint32_t Emulator::pdo_cob_id(const Drive& d, unsigned pdo) const {
  if (pdo == 4) return 0x480u + d.node;  // TPDO4, CiA 301's predefined connection set
  static constexpr const p::Message* kMessageOf[kPdoCount - 1] = {&p::kRpdo1, &p::kTpdo1,
                                                                  &p::kTpdo2, &p::kTpdo3};
  return p::cob_id(*kMessageOf[pdo], d.node);
}

delta::can::sdo::ObjectDictionary& Emulator::dictionary(unsigned j) {
  if (eds_objects_[j]) return *eds_objects_[j];
  return *objects_[j];
}

bool Emulator::mappable(unsigned j, std::uint16_t index, std::uint8_t subindex) const {
  return eds_objects_[j] ? eds_objects_[j]->mappable(index, subindex)
                         : objects_[j]->mappable(index, subindex);
}

sdo::AbortCode Emulator::set_interpolation_period(Drive& d) {
  if (d.interpolation_index < -6 || d.interpolation_index > 0) return sdo::kAbortValueRange;
  std::uint64_t us = d.interpolation_value;
  for (int k = -6; k < d.interpolation_index; ++k) us *= 10;
  if (us != 0 && (us < 100 || us > 1000000)) return sdo::kAbortValueRange;
  d.cycle_us = static_cast<std::uint32_t>(us);
  return sdo::kNoAbort;
}

std::size_t Emulator::use_eds(const delta::canopen::Eds& eds) {
  eds_ = std::make_unique<delta::canopen::Eds>(eds);
  set_product(product_of(*eds_));
  for (unsigned j = 0; j < 3; ++j) {
    Drive& d = drives_[j];
    // The rated values and encoder resolution it gives (non-zero).
    const auto given = [&](std::uint16_t index, std::uint8_t sub) -> double {
      const delta::canopen::EdsVariable* v = eds_->find(index, sub);
      const auto value = v != nullptr && !v->opaque ? v->value(d.node) : std::nullopt;
      return value && *value != 0 ? static_cast<double>(*value) : 0.0;
    };
    if (const double mA = given(0x6075, 0); mA != 0) d.model.rated_current_A = mA / 1000.0;
    if (const double mNm = given(0x6076, 0); mNm != 0) d.model.rated_torque_Nm = mNm / 1000.0;
    if (const double counts = given(0x608F, 1); counts != 0) {
      d.model.counts_per_rev = static_cast<std::uint32_t>(counts);
    }
    vendor_objects_[j] =
        std::make_unique<DriveTable>(DriveContext{*this, d}, DriveObjects::vendor_scalars(),
                                     std::span<const DriveTable::Text>());
    eds_objects_[j] = std::make_unique<EdsObjects>(
        *eds_, d.node,
        std::vector<sdo::ObjectDictionary*>{vendor_objects_[j].get(), objects_[j].get()});
    eds_objects_[j]->apply_defaults();
    sdo_servers_[j] = std::make_unique<sdo::Server>(*eds_objects_[j]);
  }
  return eds_objects_[0]->behaviour_count();
}

// The COB-ID's ID is the predefined one (it cannot move); bit 31 turns the
// PDO off and on; bit 30 (no remote request) is taken either way.
sdo::AbortCode Emulator::set_pdo_cob_id(Drive& d, unsigned pdo, std::uint32_t v) {
  if ((v & 0x3FFFFFFF) != pdo_cob_id(d, pdo)) return sdo::kAbortValueRange;
  d.pdos[pdo].valid = (v & od::kPdoInvalid) == 0;
  return sdo::kNoAbort;
}

// CiA 301's rules for a mapping: only while the PDO is off; entries only
// while sub-index 0 is 0; each entry an existing, mappable object of its
// whole size (readable for a TPDO, writable for an RPDO); at most 8 bytes.
sdo::AbortCode Emulator::set_mapping(Drive& d, unsigned pdo, unsigned sub, std::uint32_t v) {
  PdoMapping& m = d.pdos[pdo];
  if (m.valid) return sdo::kAbortValueRange;
  if (sub != 0) {
    if (m.count != 0) return sdo::kAbortValueRange;
    if (v != 0) {
      if (const sdo::AbortCode c = check_mapping_entry(d, pdo, v); c != sdo::kNoAbort) return c;
    }
    m.entries[sub - 1] = v;
    return sdo::kNoAbort;
  }
  if (v > m.entries.size()) return sdo::kAbortValueRange;
  unsigned bits = 0;
  for (unsigned i = 0; i < v; ++i) {
    if (const sdo::AbortCode c = check_mapping_entry(d, pdo, m.entries[i]); c != sdo::kNoAbort) {
      return c;
    }
    bits += m.entries[i] & 0xFF;
  }
  if (bits > 64) return sdo::kAbortPdoLength;
  m.count = static_cast<std::uint8_t>(v);
  return sdo::kNoAbort;
}

sdo::AbortCode Emulator::check_mapping_entry(const Drive& d, unsigned pdo, std::uint32_t entry) {
  const auto index = static_cast<std::uint16_t>(entry >> 16);
  const auto sub = static_cast<std::uint8_t>(entry >> 8);
  const unsigned j = d.node - p::kFirstDriveNode;
  sdo::ObjectInfo info;
  if (const sdo::AbortCode c = dictionary(j).find(index, sub, info); c != sdo::kNoAbort) return c;
  const bool usable = pdo == 0 ? info.writable : info.readable;
  if (!mappable(j, index, sub) || !usable) return sdo::kAbortNotMappable;
  if ((entry & 0xFF) != info.size * 8) return sdo::kAbortParameterIncompatible;
  return sdo::kNoAbort;
}

void Emulator::enter_fault(Drive& d, std::uint16_t emcy_code) {
  d.state = cia::State::kFault;
  d.target_torque_pm = 0;
  if (d.silent || d.nmt == p::kNmtStateStopped) return;  // CiA 301: no EMCY when stopped
  std::array<std::uint8_t, 8> data{};
  p::pack(data, p::kEmcyErrorCode, emcy_code);
  p::pack(data, p::kEmcyErrorRegister, 1);
  send(p::cob_id(p::kEmcy, d.node), 8, data);
}

void Emulator::trigger_faults() {
  for (FaultInjection& f : config_.faults) {
    if (f.done || simulated_s() + 1e-9 < f.at_s) continue;
    f.done = true;
    Drive* d = f.node != 0 ? &drives_[f.node - p::kFirstDriveNode] : nullptr;
    switch (f.kind) {
      case FaultKind::kHeartbeatDrop:
        d->heartbeat_dropped = true;
        break;
      case FaultKind::kSilent:
        d->silent = true;
        break;
      case FaultKind::kCorruptPdo:
        d->corrupt_next = true;
        break;
      case FaultKind::kDelayPdo:
        d->delay_us = f.arg_ms * 1000;
        break;
      case FaultKind::kOvercurrent:
        // The current loop sees a short: the drive trips as a real one would.
        enter_fault(*d, od::kEmcyOvercurrent);
        break;
      case FaultKind::kErrorFrame: {
        // linux/can/error.h: CAN_ERR_FLAG | CAN_ERR_CRTL, data[1] = CAN_ERR_CRTL_TX_PASSIVE;
        // then CAN_ERR_BUSOFF.
        Frame e;
        e.error_frame = true;
        e.id = 0x00000004u;
        e.dlc = 8;
        e.data[1] = 0x20;
        out_(e, 0);
        Frame off;
        off.error_frame = true;
        off.id = 0x00000040u;
        off.dlc = 8;
        out_(off, 0);
        break;
      }
    }
  }
}

std::int32_t Emulator::position_counts(const Drive& d, double q) const {
  const double motor_revs = (q - d.model.joint_zero_rad) / kTwoPi * d.model.gear_ratio;
  const double counts = std::round(motor_revs * d.model.counts_per_rev);
  return static_cast<std::int32_t>(d.model.inverted ? -counts : counts);
}

std::int32_t Emulator::velocity_counts_s(const Drive& d, double qd) const {
  const double counts_s = qd / kTwoPi * d.model.gear_ratio * d.model.counts_per_rev;
  return static_cast<std::int32_t>((d.model.inverted ? -1 : 1) * std::llround(counts_s));
}

void Emulator::advance(double dt_s) {
  bool all_enabled = true;
  for (const Drive& d : drives_)
    all_enabled = all_enabled && d.state == cia::State::kOperationEnabled;
  const int n =
      config_.substeps > 0 ? config_.substeps : (config_.plant == PlantKind::kMujoco ? 2 : 8);
  const double h = dt_s / n;
  const double decay = std::exp(-h / config_.current_time_constant_s);
  // The mean of the first-order response over a sub-step, as a fraction of
  // its start's distance from the target: (T/h)(1 - exp(-h/T)).
  const double mean_share = config_.current_time_constant_s / h * (1.0 - decay);
  for (int s = 0; s < n; ++s) {
    delta::Joint3 tau{};
    for (unsigned j = 0; j < 3; ++j) {
      Drive& d = drives_[j];
      const bool on = d.state == cia::State::kOperationEnabled;
      const double target_A = on ? target_current_A(d, h) : 0.0;
      // Exact first-order response over the sub-step; the plant gets its
      // mean torque over it.
      const double mean_A = target_A + (d.current_A - target_A) * mean_share;
      d.current_A = target_A + (d.current_A - target_A) * decay;
      const double sign = d.model.inverted ? -1.0 : 1.0;
      tau[j] = sign * d.model.gear_ratio * d.model.gearbox_efficiency *
               d.model.torque_constant_Nm_per_A() * mean_A;
    }
    if (!all_enabled) {
      plant_->stop();  // the brakes hold the arms while any drive is off
      continue;
    }
    if (!plant_->fault().empty()) continue;
    if (plant_->step(tau, h) != delta::PlantStatus::kOk) {
      for (Drive& d : drives_) enter_fault(d, 0xFF01);
    }
  }
}

// CiA 301: a SYNC consumer whose 0x1019 is 0 expects SYNCs without data,
// else with the counter's one byte; another length is reported by EMCY
// 0x8240 (error register bit 4, communication), once until a SYNC of the
// right length comes. In NMT stopped no EMCY is sent.
void Emulator::check_sync_length(Drive& d, const Frame& f) {
  const std::uint8_t expected = d.sync_counter_overflow != 0 ? 1 : 0;
  d.sync_counter = f.dlc >= 1 ? f.data[0] : 0;
  if (f.dlc == expected) {
    d.sync_length_reported = false;
    return;
  }
  if (d.sync_length_reported || d.silent || d.nmt == p::kNmtStateStopped) return;
  d.sync_length_reported = true;
  std::array<std::uint8_t, 8> data{};
  p::pack(data, p::kEmcyErrorCode, od::kEmcySyncLength);
  p::pack(data, p::kEmcyErrorRegister, 0x10);
  send(p::cob_id(p::kEmcy, d.node), 8, data);
}

void Emulator::handle_sync(const Frame& f) {
  if (last_sync_wall_us_ != 0) {
    longest_sync_gap_us_ = std::max(longest_sync_gap_us_, wall_us_ - last_sync_wall_us_);
  }
  last_sync_wall_us_ = wall_us_;
  for (Drive& d : drives_) check_sync_length(d, f);
  // Time runs from the first SYNC with operational drives.
  std::uint32_t cycle_us = 0;
  for (const Drive& d : drives_) cycle_us = d.cycle_us != 0 ? d.cycle_us : cycle_us;
  if (cycle_us == 0) cycle_us = 2000;
  if (syncs_ > 0) {
    advance(cycle_us * 1e-6);
    sim_us_ += cycle_us;
  }
  ++syncs_;
  trigger_faults();
  check_consumers([this](const Drive& d) { return sim_us_ - d.consumed_sim_us; });
  for (unsigned j = 0; j < 3; ++j) {
    Drive& d = drives_[j];
    if (d.state == cia::State::kFaultReactionActive) d.state = cia::State::kFault;
    // The heartbeat in every NMT state (by simulated time while SYNCs come).
    if (d.heartbeat_ms != 0 && sim_us_ >= d.next_heartbeat_sim_us) {
      d.next_heartbeat_sim_us = sim_us_ + std::uint64_t{d.heartbeat_ms} * 1000;
      d.last_heartbeat_wall_us = wall_us_;
      send_heartbeat(d);
    }
    if (d.nmt != p::kNmtStateOperational || d.silent) continue;
    measure(d);
    send_tpdo(j, 1);
    send_tpdo(j, 2);
    send_tpdo(j, 4);
    send_tpdo(j, 3);  // last: it tells which SYNC the others answer
  }
}

// The current, with its noise, once per SYNC: 0x6078 per mille of the
// rated current, 0x6077 in the torque unit.
void Emulator::measure(Drive& d) {
  const double measured_A = d.current_A + config_.current_noise_A * noise();
  const auto i16 = [](double v) {
    const long r = std::lround(v);
    return static_cast<std::int16_t>(std::max(-32768L, std::min(32767L, r)));
  };
  d.current_measured_pm = i16(measured_A / d.model.rated_current_A * 1000.0);
  const double torque_Nm = measured_A * d.model.torque_constant_Nm_per_A();
  switch (config_.torque_unit) {
    case TorqueUnit::kPerMille:
      d.torque_measured = i16(torque_Nm / d.model.rated_torque_Nm * 1000.0);
      break;
    case TorqueUnit::kMilliamp:
      d.torque_measured = i16(measured_A * 1000.0);
      break;
    case TorqueUnit::kMilliNewtonMetre:
      d.torque_measured = i16(torque_Nm * 1000.0);
      break;
  }
}

// The current set-point of the target torque (0x6071 in the torque unit),
// within the maximum current (0x6073) and torque (0x6072); in profile
// torque the set-point follows at the torque slope (0x6087, 0: at once).
double Emulator::target_current_A(Drive& d, double dt_s) {
  const double kt = d.model.torque_constant_Nm_per_A();
  double target_A = 0.0;
  switch (config_.torque_unit) {
    case TorqueUnit::kPerMille:
      target_A = d.target_torque_pm / 1000.0 * d.model.rated_torque_Nm / kt;
      break;
    case TorqueUnit::kMilliamp:
      target_A = d.target_torque_pm / 1000.0;
      break;
    case TorqueUnit::kMilliNewtonMetre:
      target_A = d.target_torque_pm / 1000.0 / kt;
      break;
  }
  double limit_A = d.max_current_pm / 1000.0 * d.model.rated_current_A;
  if (d.max_torque_pm != 0xFFFF) {
    limit_A = std::min(limit_A, d.max_torque_pm / 1000.0 * d.model.rated_torque_Nm / kt);
  }
  target_A = std::clamp(target_A, -limit_A, limit_A);
  if (d.mode == cia::kModeProfileTorque && d.torque_slope_pm_s != 0) {
    const double step_A = d.torque_slope_pm_s / 1000.0 * d.model.rated_torque_Nm / kt * dt_s;
    target_A = std::clamp(target_A, d.ramped_A - step_A, d.ramped_A + step_A);
  }
  d.ramped_A = target_A;
  return target_A;
}

std::string Emulator::describe() const {
  std::ostringstream s;
  for (const Drive& d : drives_) {
    s << "node " << int{d.node} << ": NMT " << int{d.nmt} << ", " << state_text(d.state)
      << (d.silent ? " (silent)" : "") << "\n";
  }
  for (const SentEmergency& e : emergencies_) {
    s << "node " << int{e.node} << " sent EMCY 0x" << std::hex << std::uppercase << std::setw(4)
      << std::setfill('0') << e.code << std::dec << " (" << od::emcy_meaning(e.code) << ") at "
      << e.simulated_s << " s simulated\n";
  }
  return s.str();
}

}  // namespace emu
