// The emulated drives on the bus: construction, NMT, SDO, heartbeats and
// SYNCs; their faults, PDOs and physics are in emulator_faults.cpp,
// emulator_pdo.cpp and emulator_physics.cpp.
#include "emu/emulator.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "delta/drive_train_plant.hpp"
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

std::unique_ptr<delta::Plant> make_plant(const EmulatorConfig& c) {
  if (c.plant == PlantKind::kMujoco) {
    // With the robot's drive train, where its description has one.
    return std::make_unique<delta::MultibodyRobot>(
        c.robot, c.initial_q_rad,
        delta::MujocoSettings{delta::MujocoIntegrator::kEuler, delta::kMujocoCoarsestStep_s});
  }
  return std::make_unique<delta::LumpedPlant>(c.geometry, c.truth, c.initial_q_rad);
}

}  // namespace

Emulator::Emulator(const EmulatorConfig& config, Outbox out)
    : config_(config), out_(std::move(out)), plant_(make_plant(config)), rng_(config.seed) {
  for (const FaultInjection& f : config.faults) {
    if (f.kind == FaultKind::kContact && !plant_->set_platform_force({0.0, 0.0, 0.0})) {
      throw std::invalid_argument(
          "--inject contact needs a platform to push: --plant mujoco (the lumped plant has none)");
    }
  }
  for (unsigned j = 0; j < 3; ++j) {
    drives_[j].node = static_cast<std::uint8_t>(p::kFirstDriveNode + j);
    drives_[j].model = config.drives[j];
    drives_[j].pdos = product_.pdos;
    if (config.plant == PlantKind::kMujoco) {
      drives_[j].reported_A =
          delta::CurrentFilter(config.robot.joints[j].current_filter_time_constant_s);
    }
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
  if (take_rpdo(f)) return;
  const std::uint8_t node = p::node_id(f.id);
  if (node < p::kFirstDriveNode || node >= p::kFirstDriveNode + p::kDriveCount) return;
  const unsigned j = node - p::kFirstDriveNode;
  if (!drives_[j].silent && p::function_code(f.id) == p::kSdoRx.base_id) handle_sdo(j, f);
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

delta::can::sdo::ObjectDictionary& Emulator::dictionary(unsigned j) {
  if (eds_objects_[j]) return *eds_objects_[j];
  return *objects_[j];
}

sdo::AbortCode Emulator::set_interpolation_period(Drive& d) {
  if (d.interpolation_index < -6 || d.interpolation_index > 0) return sdo::kAbortValueRange;
  std::uint64_t us = d.interpolation_value;
  for (int k = -6; k < d.interpolation_index; ++k) us *= 10;
  if (us != 0 && (us < 100 || us > 1000000)) return sdo::kAbortValueRange;
  d.cycle_us = static_cast<std::uint32_t>(us);
  return sdo::kNoAbort;
}

void Emulator::enter_fault(Drive& d, std::uint16_t emcy_code) {
  d.state = cia::State::kFault;
  end_arm_run(static_cast<unsigned>(&d - drives_.data()));
  d.target_torque_pm = 0;
  if (d.silent || d.nmt == p::kNmtStateStopped) return;  // CiA 301: no EMCY when stopped
  std::array<std::uint8_t, 8> data{};
  p::pack(data, p::kEmcyErrorCode, emcy_code);
  p::pack(data, p::kEmcyErrorRegister, 1);
  send(p::cob_id(p::kEmcy, d.node), 8, data);
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
    send_tpdo(j, 6);
    send_tpdo(j, 3);  // last: it tells which SYNC the others answer
  }
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
