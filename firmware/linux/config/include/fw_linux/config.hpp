// The Linux port's configuration: `key = value` lines (docs/firmware.md
// lists every key). Values are read in SI units as decimals and converted to
// the core's Q formats once, here, with range checks; the core never sees a
// double.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "delta/canopen/eds.hpp"
#include "delta/drive_model.hpp"
#include "delta/geometry.hpp"
#include "delta/identified_model.hpp"
#include "delta/robot_description.hpp"
#include "fw/controller.hpp"
#include "fw_linux/allow_list.hpp"

namespace fw_linux {

// A configuration error: the message names the file, line and column.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class CycleMode : std::uint8_t {
  kRealTime,  // a timerfd tick every period
  kLockStep,  // the next cycle starts when the last exchange completed
};

// The identity (0x1018) a drive must show at bring-up: from its EDS's
// [DeviceInfo] (jointN.eds) and jointN.serial. Unset parts are not checked.
struct DriveIdentity {
  std::optional<std::uint32_t> vendor_id;
  std::optional<std::uint32_t> product_code;
  std::optional<std::uint32_t> revision;  // its major part (high 16 bits) must match
  std::optional<std::uint32_t> serial;
  std::string source;  // where the expectation comes from, for messages
};

// The unit of a drive's target torque (0x6071) and torque actual value
// (0x6077): CiA 402's per mille of the motor rated torque (0x6076), or,
// as some vendors do, the motor current in mA or the torque in mN m.
enum class TorqueUnit : std::uint8_t { kPerMille, kMilliamp, kMilliNewtonMetre };

struct JointDrive {
  std::uint8_t node{1};
  delta::DriveModel model{delta::kDefaultDrive};
  double torque_offset_Nm{0.0};
  std::string eds_path;  // empty: the generic CiA 402 profile, any identity
  std::shared_ptr<const delta::canopen::Eds> eds;  // read from eds_path
  DriveIdentity identity;
  TorqueUnit torque_unit{TorqueUnit::kPerMille};
  // Which of the drive's values the configuration sets (else the EDS, the
  // drive or the default drive gives them).
  bool rated_current_set{false};
  bool rated_torque_set{false};
  bool counts_per_rev_set{false};
  bool torque_unit_set{false};
};

inline JointDrive joint_on_node(std::uint8_t node) {
  JointDrive j;
  j.node = node;
  return j;
}

// The Modbus server (docs/modbus.md). Off unless tcp or rtu_device is set.
struct ModbusConfig {
  std::string tcp;         // "ADDRESS:PORT" (e.g. 0.0.0.0:1502); empty: no TCP server
  std::string rtu_device;  // a serial device (e.g. /dev/ttyUSB0); empty: no RTU server
  std::uint32_t rtu_baud{115200};
  char rtu_parity{'N'};  // N, E or O
  std::uint32_t rtu_unit_id{1};
  // TCP: the networks whose clients may write (fw_linux/allow_list.hpp);
  // any client may read.
  std::string allow{kDefaultModbusAllow};
  std::uint32_t max_clients{8};            // TCP connections served at once; more are closed
  std::uint32_t byte_timeout_ms{200};      // a request that stops mid-way is dropped after this
  std::uint32_t idle_timeout_ms{30000};    // TCP: a connection without a request is closed
  std::uint32_t command_timeout_ms{1000};  // wait for the control loop to take a command
};

// The safety lines on a GPIO chip (libgpiod). Empty chip: simulated lines
// (the e-stop closed), for the emulator and tests.
struct GpioConfig {
  std::string chip;  // "gpiochip0", "/dev/gpiochip0" or a label
  std::uint32_t estop_line{0};
  std::uint32_t enable_line{1};
  std::uint32_t brake_line{2};
  std::uint32_t status_line{3};
  std::uint32_t estop_debounce_ms{20};  // closed this long before the e-stop counts as closed
  std::string consumer{"delta_fw"};
};

struct PortConfig {
  std::uint32_t period_us{2000};  // 500 Hz: the bus budget (docs/protocol.md)
  CycleMode mode{CycleMode::kRealTime};
  std::uint32_t response_window_us{0};      // real time: wait for the TPDOs; 0 = half the period
  std::uint32_t lockstep_timeout_ms{1000};  // lock-step: give up on a response after this
  bool velocity_pdo{false};                 // map TPDO2 (velocity); else differences of position
  // Map each drive's arm-side encoder (0x60E4:1, in 0x6064's position
  // units) into its TPDO4 and log the arm angles (LOG_D, LOG_E).
  bool arm_encoders{false};
  // The bus's bit rate, for the bus-load check only (fw_linux/bus_load.hpp):
  // the interface's own is set outside delta_fw (ip link ... bitrate).
  std::uint32_t can_bitrate{1000000};
  // CiA 301's 0x1019: 0, SYNC without data; 2..240, SYNC carries a counter
  // that wraps after this value, the drives' TPDO3 echoes it, and a cycle's
  // TPDOs count only with this cycle's counter (docs/protocol.md).
  std::uint8_t sync_counter_overflow{0};
  std::uint16_t heartbeat_ms{50};  // written to the drives (0x1017)
  std::uint32_t heartbeat_timeout_ms{150};
  // How long a drive waits for the controller's heartbeat before it faults
  // (EMCY 0x8130) and disables: written to the drives' 0x1016:1; 0 = off.
  std::uint16_t controller_heartbeat_timeout_ms{150};
  std::uint32_t sdo_timeout_ms{100};
  std::uint32_t sdo_retries{2};
  // robot = FILE: the robot description (docs/robot-description.md) gives
  // the geometry, the gear ratios, the limits it has and the nominal
  // feed-forward (adopt_robot); a key set here as well must agree.
  std::string robot_file;
  std::optional<delta::RobotDescription> robot;
  // Where each key was set (file:line:column, or "--set KEY").
  std::map<std::string, std::string> set_where;
  std::array<JointDrive, 3> joints{joint_on_node(1), joint_on_node(2), joint_on_node(3)};
  delta::Geometry geometry{delta::kDefaultGeometry};

  double min_rad{-1.2};
  double max_rad{1.4};
  double max_velocity_rad_s{6.0};
  double max_acceleration_rad_s2{150.0};
  double max_tracking_error_rad{0.1};
  double kp_Nm_per_rad{60.0};
  double kd_Nm_s_per_rad{1.5};
  double ki_Nm_per_rad_s{0.0};
  double max_torque_Nm{8.0};
  double integral_limit_Nm{1.0};
  double nominal_arm_inertia_kg_m2{-1.0};  // < 0: from the default robot's model
  double nominal_gravity_moment_Nm{-1.0};
  // The feed-forward (fw/feed_forward.hpp): feed_forward = off | nominal |
  // model; with feed_forward.model = RESULT.json (a saved host_id fit) and
  // no feed_forward key, model.
  fw::FeedForwardMode feed_forward{fw::FeedForwardMode::kNominal};
  bool feed_forward_set{false};
  std::string feed_forward_model_file;
  std::optional<delta::IdentifiedModel> feed_forward_model;
  // With a model that has its gearboxes' stiffness (an elastic fit): the
  // motors track past the arms' reference by the deflection
  // (fw/deflection.hpp); false turns it off.
  bool deflection_compensation{true};
  // Where a model loaded over the bus is kept across restarts (written
  // atomically); "": not kept.
  std::string feed_forward_store{"delta_fw_model.bin"};
  // Collision detection (fw/collision.hpp, docs/safety.md;
  // fw_linux/collision_setting.hpp): collision.detect unset is on where the
  // model in use carries its thresholds, off otherwise. The keys'
  // thresholds (N m; per rad/s; per rad/s^2, every joint alike) replace the
  // model's where collision.threshold_Nm is given.
  std::optional<bool> collision_detect;
  double collision_threshold_scale{1.0};
  std::optional<double> collision_threshold_Nm;
  double collision_threshold_per_speed{0.0};
  double collision_threshold_per_acceleration{0.0};
  double approach_s{2.0};
  double stop_s{0.4};
  double blend_s{1.0};  // Fourier excitations fade in and out over this
  // The custom trajectory's holding registers at start (trajectory_file,
  // docs/firmware.md); empty: none.
  std::string custom_trajectory_file;
  std::vector<std::uint16_t> custom_block;
  std::uint32_t lost_feedback_cycles{3};
  std::uint32_t configure_timeout_ms{5000};
  ModbusConfig modbus{};
  GpioConfig gpio{};
};

// "ADDRESS:PORT" split; throws ConfigError naming `what`.
std::pair<std::string, int> split_host_port(const std::string& text, const std::string& what);

// Reads a configuration file over the defaults. Throws ConfigError; with
// `problems`, a wrong line or value is added there and the reading goes on
// (only a file that cannot be opened throws).
PortConfig read_port_config(const std::string& path, std::vector<std::string>* problems = nullptr);

// Only the file's keys over c, without finish_config(). Throws ConfigError
// (with `problems`, as read_port_config).
void read_config_lines(PortConfig& c, const std::string& path,
                       std::vector<std::string>* problems = nullptr);

// What comes after the keys (a file's, or --set's): the EDS's values for
// what the configuration does not set, then validate() (or, with
// `problems`, every problem added there).
void finish_config(PortConfig& c, std::vector<std::string>* problems = nullptr);

// robot = FILE's values where the configuration does not set their keys;
// a key it sets to another value is a problem naming both places.
void adopt_robot(PortConfig& c, std::vector<std::string>& problems);
// "robot: FILE (NAME): arms ..., gear ratios ...; joint range ..." as the
// controller runs it; "" without robot = FILE.
std::string describe_robot(const PortConfig& c);

// Applies one `key = value` (the file's lines and --set on the command line
// use it). `where` prefixes error messages ("file:line:column").
void set_config_value(PortConfig& c, const std::string& key, const std::string& value,
                      const std::string& where);

// Every problem of the whole configuration (ranges, distinct nodes, a
// period that divides one second, each drive's plan: drive_plan.hpp).
std::vector<std::string> configuration_problems(const PortConfig& c);

// "feed-forward: model (delta, fit 0x1A2B3C4D, RESULT.json)", or nominal
// with its two values, or off: what the controller starts with.
std::string describe_feed_forward(const PortConfig& c);
// Whether the controller compensates the gearboxes' deflection with `f`
// and with which stiffness, or why not (a model with stiffness, the key
// off); "" for a rigid model or another mode.
std::string describe_deflection(const fw::FeedForwardConfig& f);

// Throws ConfigError with every problem, a line each.
void validate(const PortConfig& c);

// The core's configuration in Q formats. Throws ConfigError when a value
// does not fit its format.
fw::ControllerConfig controller_config(const PortConfig& c);

// A value in a Q format, rounded to nearest; throws ConfigError naming
// `what` when it does not fit.
template <class Q>
Q to_q(double v, const char* what);

}  // namespace fw_linux
