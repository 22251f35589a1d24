// The drive-and-robot emulator: three CiA 402 drives on one CAN bus, coupled
// to a simulated delta (delta/plant.hpp: the multibody MuJoCo robot of a
// robot description, or the lumped model integrated with RK4), stepped in
// sub-steps of each SYNC cycle, with fault injection. Socket-free: frames come in
// through on_frame() and leave through the Outbox, so the same code serves
// delta_drive_emu on SocketCAN and unit tests.
//
// Each drive has the CiA 402 power state machine (common/can/cia402.hpp), an
// SDO server with an object dictionary, TPDOs on SYNC, a heartbeat producer,
// EMCY on faults, a first-order current loop, encoder quantisation and
// Gaussian current noise. Simulated time advances by the communication cycle
// period (object 0x1006) at every SYNC, so a lock-step controller gets the
// same physics whatever the machine's speed.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "delta/can/cia402.hpp"
#include "delta/can/sdo.hpp"
#include "delta/can/socketcan.hpp"
#include "delta/canopen/eds.hpp"
#include "delta/canopen/object_table.hpp"
#include "delta/drive_model.hpp"
#include "delta/drive_train_plant.hpp"
#include "delta/dynamics.hpp"
#include "delta/plant.hpp"
#include "delta/robot_description.hpp"
#include "delta/splitmix.hpp"
#include "emu/arm_tracking.hpp"
#include "emu/drive_settings.hpp"

namespace emu {

// One injected fault (docs/hil.md): KIND[:NODE[:ARG]][@SECONDS].
enum class FaultKind : std::uint8_t {
  kHeartbeatDrop,  // the node stops its heartbeat (PDOs continue)
  kSilent,         // the node stops answering anything
  kErrorFrame,     // error frames on the bus: error passive, then bus-off
  kCorruptPdo,     // the node's next TPDO1 is 5 bytes long
  kDelayPdo,       // the node's TPDOs leave ARG ms (wall clock) after the SYNC
  kOvercurrent,    // the node's current exceeds its limit: fault, EMCY 0x2310
  kContact,        // a force on the platform for ARG ms (the MuJoCo plant's)
};

struct FaultInjection {
  FaultKind kind{FaultKind::kSilent};
  std::uint8_t node{0};             // 0 for bus-wide faults
  double at_s{0.0};                 // simulated time after the first SYNC
  std::uint32_t arg_ms{0};          // delay-pdo, contact
  std::array<double, 3> force_N{};  // contact: the force, world frame
  bool done{false};
  bool ended{false};  // contact: the force is off again
};

// Parses "silent:2@1.5", "error-frame@3", "delay-pdo:1:15@0.5",
// "contact:10:1,0,0:200@2.5" (FORCE_N:DX,DY,DZ:MS, the direction
// normalised). Throws
// std::invalid_argument with the reason.
FaultInjection parse_fault(const std::string& spec);

enum class PlantKind : std::uint8_t {
  kLumped,  // the lumped model with `truth` on `geometry`: fast, for unit tests
  kMujoco,  // the multibody robot of `robot` (delta_drive_emu's default)
};

// The emulated drives' product: identity (0x1018), name (0x1008) and the
// PDOs' default mapping. The default vendor ID is not one CiA assigned: no
// real drive has it.
inline constexpr std::uint32_t kEmulatorVendorId = 0x0000DE17;
inline constexpr std::uint32_t kEmulatorProductCode = 0x00000402;
inline constexpr std::uint32_t kEmulatorRevision = 0x00010000;

// A PDO's communication validity and mapping (CiA 301): each entry is
// index << 16 | sub-index << 8 | length in bits.
struct PdoMapping {
  bool valid{false};  // bit 31 of the COB-ID clear
  std::uint8_t count{0};
  std::array<std::uint32_t, 8> entries{};
  // CiA 301: 0 synchronous when changed, 1 to 240 every that many SYNCs,
  // 254 and 255 when changed (event-driven), 252 and 253 on request only.
  std::uint8_t transmission{1};
  // RPDO5 and TPDO5, which CiA 301 gives no predefined COB-ID: theirs
  // (11 bits), plus the node ID where the EDS's default adds $NODEID.
  std::uint16_t id{0};
  bool id_plus_node{false};
};

// RPDO1, TPDO1 to TPDO4, RPDO5, TPDO5: TPDO1 to TPDO4 as
// docs/protocol.md's table lays them out (TPDO4 off and empty until the
// controller maps the arm-side encoder); RPDO5 and TPDO5 only where a
// drive's EDS has them (--eds: a vendor's fixed PDOs).
inline constexpr unsigned kPdoCount = 7;
inline constexpr std::uint16_t kPdoCommunication[kPdoCount] = {0x1400, 0x1800, 0x1801, 0x1802,
                                                               0x1803, 0x1404, 0x1804};
inline constexpr bool receive_pdo(unsigned pdo) {
  return pdo == 0 || pdo == 5;
}
inline constexpr std::array<PdoMapping, kPdoCount> kDefaultPdos{
    PdoMapping{true, 3, {0x60400010, 0x60710010, 0x607A0020}},
    PdoMapping{true, 3, {0x60410010, 0x60640020, 0x60780010}},
    PdoMapping{false, 1, {0x606C0020}},
    PdoMapping{false, 1, {0x20190008}},
    PdoMapping{false, 0, {}},
    PdoMapping{false, 0, {}},
    PdoMapping{false, 0, {}}};

// The CiA 402 modes a drive takes in 0x6060 (bits of 0x6502): cyclic
// synchronous torque (bit 9) and profile torque (bit 3) are emulated.
inline constexpr std::uint32_t kModeBitCst = 1u << 9;
inline constexpr std::uint32_t kModeBitProfileTorque = 1u << 3;

// The unit of 0x6071 and 0x6077 (CiA 402: per mille of 0x6076).
enum class TorqueUnit : std::uint8_t { kPerMille, kMilliamp, kMilliNewtonMetre };

struct EmulatedProduct {
  std::uint32_t vendor_id{kEmulatorVendorId};
  std::uint32_t product_code{kEmulatorProductCode};
  std::uint32_t revision{kEmulatorRevision};
  std::string device_name{"Delta emulated CiA 402 drive"};
  std::array<PdoMapping, kPdoCount> pdos{kDefaultPdos};  // as kPdoCommunication
  std::uint32_t supported_modes{kModeBitCst};            // 0x6502
  // The serial number is 0x00010000 + the node ID.
};

// The product an EDS describes: [DeviceInfo], 0x1008's DefaultValue, the
// default PDO validity (0x1400:1, 0x1800:1 to 0x1803:1), transmission
// types and mappings (0x1600, 0x1A00 to 0x1A03), the supported modes
// (0x6502).
EmulatedProduct product_of(const delta::canopen::Eds& eds);

class EdsObjects;

struct EmulatorConfig {
  PlantKind plant{PlantKind::kLumped};
  delta::RobotDescription robot{delta::default_robot_description()};
  delta::Geometry geometry{delta::kDefaultGeometry};  // = robot.geometry for kMujoco
  delta::LumpedParameters truth{delta::default_lumped_parameters()};
  std::array<delta::DriveModel, 3> drives{delta::kDefaultDrive, delta::kDefaultDrive,
                                          delta::kDefaultDrive};
  delta::Joint3 initial_q_rad{0.45, 0.45, 0.45};
  double current_time_constant_s{0.0003};  // current loop
  double current_noise_A{0.005};           // standard deviation
  // Plant steps per cycle, each with the current loop's mean torque over
  // it; 0: the plant's own (lumped 8, RK4; mujoco 2, MuJoCo steps of at
  // most delta::kMujocoCoarsestStep_s: 1 ms at the default 500 Hz).
  int substeps{0};
  std::uint64_t seed{1};
  std::vector<FaultInjection> faults;
  TorqueUnit torque_unit{TorqueUnit::kPerMille};
  // The controller's approach_s and stop_s: the span of its `tracking` line,
  // which the `arm tracking` line covers too (emu/arm_tracking.hpp).
  double approach_s{2.0};
  double stop_s{0.4};
  // Lines for the user (`contact: t_s=T force_N=F`, `arm tracking: ...`);
  // none where unset.
  std::function<void(const std::string&)> report;
};

// Frames leave with a delay (wall clock, microseconds; 0 = now).
using Outbox = std::function<void(const delta::can::Frame&, std::uint32_t delay_us)>;

class Emulator {
 public:
  Emulator(const EmulatorConfig& config, Outbox out);
  ~Emulator();
  Emulator(const Emulator&) = delete;
  Emulator& operator=(const Emulator&) = delete;

  // The drives' boot-up messages.
  void boot();
  void on_frame(const delta::can::Frame& f);
  // The wall clock, for the frames that on_frame() then gets.
  void set_wall_time(std::uint64_t now_us) { wall_us_ = now_us; }
  // Heartbeats by wall clock while no SYNC comes (pre-operational), the
  // consumers' supervision once SYNCs stopped, SDO timeouts.
  void on_wall_time(std::uint64_t now_us);

  double simulated_s() const { return static_cast<double>(sim_us_) * 1e-6; }
  std::uint64_t syncs() const { return syncs_; }
  // The longest wall-clock wait from one SYNC to the next [s]: how far a
  // starved machine stretched the run (the consumers' wall-clock grace
  // must stay above it).
  double longest_sync_gap_s() const { return static_cast<double>(longest_sync_gap_us_) * 1e-6; }
  delta::Joint3 q_rad() const { return plant_->state().q_rad; }
  delta::Joint3 qd_rad_s() const { return plant_->state().qd_rad_s; }
  delta::can::cia402::State drive_state(unsigned j) const { return drives_[j].state; }
  std::uint8_t nmt_state(unsigned j) const { return drives_[j].nmt; }
  // A drive's motor current [A] (the current loop's state).
  double current_A(unsigned j) const { return drives_[j].current_A; }
  // A PDO's transmission type (0 RPDO1, 1 to 4 TPDO1 to TPDO4).
  std::uint8_t tpdo_transmission(unsigned j, unsigned pdo) const {
    return drives_[j].pdos[pdo].transmission;
  }
  // The drives' identity and name (default: EmulatedProduct{}).
  void set_product(const EmulatedProduct& product) {
    product_ = product;
    for (Drive& d : drives_) d.pdos = product.pdos;
  }
  // Where an EDS and the emulated drive's objects disagree (an object one
  // has and the other not, a size, an access), in words; "" if they agree.
  std::string eds_mismatch(const delta::canopen::Eds& eds);
  // The drives become the drive `eds` describes (delta_drive_emu --eds):
  // exactly its objects with their access, sizes and defaults, its
  // product (product_of), its rated values (0x6075, 0x6076, 0x608F:1
  // where it gives them). Objects without an emulated behaviour keep their
  // values. Returns how many of the EDS's objects have one.
  std::size_t use_eds(const delta::canopen::Eds& eds);
  // The values the user commissioned the drives with (after use_eds: they
  // take the place of its defaults), and their torque unit where given.
  void commission(const CommissionedDrives& c);
  // A line per drive: node, NMT state, CiA 402 state; then a line per EMCY
  // the drives sent (the first kEmergenciesKept).
  std::string describe() const;
  // Set when the plant faulted (diverged, ran away, left the workspace, its
  // chains came apart): the drives are in fault and the run is broken.
  const std::string& plant_error() const { return plant_->fault(); }

 private:
  struct Drive {
    std::uint8_t node{0};
    delta::DriveModel model{};
    std::uint8_t nmt{127};
    delta::can::cia402::State state{delta::can::cia402::State::kNotReadyToSwitchOn};
    std::uint16_t controlword{0};
    std::int16_t target_torque_pm{0};
    std::int8_t mode{0};
    std::uint32_t cycle_us{0};
    std::uint16_t heartbeat_ms{0};
    std::array<PdoMapping, kPdoCount> pdos{};  // as kPdoCommunication
    // What each TPDO sent last (event-driven and type 0 send on change),
    // and the SYNCs since (types 2 to 240).
    std::array<std::array<std::uint8_t, 9>, kPdoCount> last_sent{};
    std::array<std::uint8_t, kPdoCount> syncs_since{};
    std::uint16_t max_torque_pm{0xFFFF};  // 0x6072 (0xFFFF: no limit of its own)
    std::uint32_t torque_slope_pm_s{0};   // 0x6087, profile torque (0: none)
    std::int16_t torque_measured{0};      // 0x6077 in the torque unit, per SYNC
    double ramped_A{0.0};                 // profile torque: the set-point after the slope
    std::uint8_t interpolation_value{0};  // 0x60C2:1
    std::int8_t interpolation_index{-3};  // 0x60C2:2: 10^index s
    // The SYNC consumer (CiA 301): 0x1019, the counter of the last SYNC
    // (0x2019, TPDO3 carries it), and whether a SYNC of the wrong length
    // was reported (EMCY 0x8240, once until a SYNC of the right one).
    std::uint8_t sync_counter_overflow{0};
    std::uint8_t sync_counter{0};
    bool sync_length_reported{false};
    std::int32_t target_position{0};      // 0x607A: the arm reference (arm tracking)
    std::int16_t current_measured_pm{0};  // 0x6078, with the noise, per SYNC
    std::uint16_t max_current_pm{3000};
    double current_A{0.0};
    // What the drive's current measurement reports: the current through
    // the robot description's current filter (none: the current itself).
    delta::CurrentFilter reported_A{};
    std::uint64_t next_heartbeat_sim_us{0};
    std::uint64_t last_heartbeat_wall_us{0};
    // The heartbeat consumer (0x1016:1): node << 16 | timeout ms. Armed by
    // the first heartbeat of that node; checked while operational, in
    // simulated time while SYNCs come and in wall time when they stop.
    std::uint32_t consumer{0};
    bool consumer_armed{false};
    std::uint64_t consumed_sim_us{0};
    std::uint64_t consumed_wall_us{0};
    // injected faults
    bool silent{false};
    bool heartbeat_dropped{false};
    bool corrupt_next{false};
    std::uint32_t delay_us{0};
  };
  struct DriveContext;  // a drive's object dictionary (drive_objects.hpp)
  class DriveObjects;
  using DriveTable = delta::canopen::ObjectTable<DriveContext>;
  // The drive's dictionary: the EDS's (use_eds) or the built-in table.
  delta::can::sdo::ObjectDictionary& dictionary(unsigned j);
  bool mappable(unsigned j, std::uint16_t index, std::uint8_t subindex) const;
  bool tpdo_due(Drive& d, unsigned pdo, const std::array<std::uint8_t, 9>& payload);
  // 0x60C2 into the cycle period (as 0x1006 sets it).
  delta::can::sdo::AbortCode set_interpolation_period(Drive& d);
  double target_current_A(Drive& d, double dt_s);
  void measure(Drive& d);

  void handle_nmt(const delta::can::Frame& f);
  void handle_sdo(unsigned j, const delta::can::Frame& f);
  void flush_sdo(unsigned j);
  void reset_application(Drive& d);
  void apply_controlword(Drive& d, std::uint16_t controlword);
  void handle_rpdo(unsigned j, unsigned pdo, const delta::can::Frame& f);
  bool take_rpdo(const delta::can::Frame& f);
  // The arm's tracking error at this RPDO's reference (0x607A), or the end
  // of the drive's run once it is no longer enabled.
  void track_arm(unsigned j, const PdoMapping& m);
  void end_arm_run(unsigned j);
  void send_tpdo(unsigned j, unsigned pdo);
  std::uint32_t pdo_cob_id(const Drive& d, unsigned pdo) const;
  delta::can::sdo::AbortCode set_pdo_cob_id(Drive& d, unsigned pdo, std::uint32_t v);
  delta::can::sdo::AbortCode set_mapping(Drive& d, unsigned pdo, unsigned sub, std::uint32_t v);
  delta::can::sdo::AbortCode check_mapping_entry(const Drive& d, unsigned pdo, std::uint32_t entry);
  void handle_sync(const delta::can::Frame& f);
  void check_sync_length(Drive& d, const delta::can::Frame& f);
  void handle_consumed_heartbeat(std::uint8_t node);
  // Faults the drives whose consumer timed out: elapsed since the last
  // heartbeat as measured by `elapsed_us`.
  template <class Elapsed>
  void check_consumers(Elapsed elapsed_us);
  void advance(double dt_s);
  void trigger_faults();
  void enter_fault(Drive& d, std::uint16_t emcy_code);
  void send_heartbeat(Drive& d);
  void send(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data,
            std::uint32_t delay_us = 0);
  double noise();
  std::int32_t position_counts(const Drive& d, double q) const;
  std::int32_t velocity_counts_s(const Drive& d, double qd) const;
  double joint_angle_rad(const Drive& d, std::int32_t counts) const;

  EmulatorConfig config_;
  EmulatedProduct product_;
  Outbox out_;
  std::array<Drive, 3> drives_{};
  std::array<std::unique_ptr<DriveTable>, 3> objects_;
  // Objects vendors' drives have beyond the built-in ones (--eds only).
  std::array<std::unique_ptr<DriveTable>, 3> vendor_objects_;
  std::array<std::unique_ptr<EdsObjects>, 3> eds_objects_;
  std::array<std::unique_ptr<delta::can::sdo::Server>, 3> sdo_servers_;
  std::unique_ptr<delta::canopen::Eds> eds_;  // use_eds()
  std::unique_ptr<delta::Plant> plant_;
  std::optional<ArmTracking> arm_tracking_;  // from the first enabled cycle
  std::uint64_t sim_us_{0};
  std::uint64_t syncs_{0};
  delta::SplitMix64 rng_;
  std::uint64_t wall_us_{0};
  std::uint64_t last_sync_wall_us_{0};
  std::uint64_t longest_sync_gap_us_{0};
  struct SentEmergency {
    std::uint8_t node;
    std::uint16_t code;
    double simulated_s;
  };
  static constexpr std::size_t kEmergenciesKept = 32;
  std::vector<SentEmergency> emergencies_;
};

}  // namespace emu
