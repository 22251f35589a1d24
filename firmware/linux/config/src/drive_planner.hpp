// The planning of one drive's bring-up from its EDS (or the generic CiA
// 402 profile), internal to delta_fw_config: plan_drives() runs a Planner
// per joint. Its settings (identity, scaling, mode, cycle, limits,
// heartbeats) are planned in drive_planner.cpp, its PDOs in
// drive_planner_pdos.cpp.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "delta/can/protocol.hpp"
#include "delta/canopen/eds.hpp"
#include "fw_linux/drive_plan.hpp"

namespace fw_linux::planning {

namespace od = delta::can::od;
namespace co = delta::canopen;

// "0x002A" for hex(42, 4).
std::string hex(std::uint32_t v, int digits);

inline std::uint32_t entry(od::Object o, unsigned bits) {
  return std::uint32_t{o.index} << 16 | std::uint32_t{o.subindex} << 8 | bits;
}

constexpr od::Object kTargetTorque{0x6071, 0};
constexpr od::Object kTargetPosition{0x607A, 0};
constexpr od::Object kPositionActual{0x6064, 0};
constexpr od::Object kVelocityActual{0x606C, 0};
// CiA 402's additional position actual value: the first additional (here
// arm-side) encoder, in the position units of 0x6064.
constexpr od::Object kArmPositionActual{0x60E4, 1};
constexpr od::Object kTorqueActual{0x6077, 0};
constexpr od::Object kCurrentActual{0x6078, 0};
constexpr od::Object kMaxTorque{0x6072, 0};
constexpr od::Object kTorqueSlope{0x6087, 0};
constexpr od::Object kSupportedModes{0x6502, 0};
constexpr od::Object kInterpolationPeriodValue{0x60C2, 1};
constexpr od::Object kInterpolationPeriodIndex{0x60C2, 2};
// 0x6502's bits (CiA 402): profile torque, cyclic synchronous torque.
constexpr std::uint32_t kSupportsProfileTorque = 1u << 3;
constexpr std::uint32_t kSupportsCst = 1u << 9;
// A PDO COB-ID's bit 30: no remote transmission request (CiA 301).
constexpr std::uint32_t kNoRtr = 1u << 30;

// One PDO's objects: its communication (0x1400/0x1800 + n - 1) and
// mapping (0x1600/0x1A00 + n - 1) indices. CiA 301's predefined COB-IDs
// are PDO1 to PDO4's: a PDO above them takes the COB-ID of one of those
// that the controller turns off (`id_of`).
struct PdoObjects {
  bool receive;
  unsigned number;
  unsigned id_of{0};  // the predefined PDO whose COB-ID it takes; 0: its own
  std::uint16_t communication() const {
    return static_cast<std::uint16_t>((receive ? 0x1400 : 0x1800) + number - 1);
  }
  std::uint16_t mapping() const {
    return static_cast<std::uint16_t>((receive ? 0x1600 : 0x1A00) + number - 1);
  }
  std::uint32_t cob_id(std::uint8_t node) const {
    const unsigned n = id_of != 0 ? id_of : number;
    return (receive ? 0x200u : 0x180u) + 0x100u * (n - 1) + node;
  }
  std::string name() const { return (receive ? "RPDO" : "TPDO") + std::to_string(number); }
};

// An object a PDO carries: its size in the generic profile, whether the
// controller can do without it.
struct Wanted {
  od::Object object;
  unsigned generic_bits;
  const char* name;
  bool optional{false};
};

// The planning of one drive; `eds` null for the generic profile.
class Planner {
 public:
  Planner(const PortConfig& c, unsigned joint, DrivePlan& plan, std::vector<std::string>& problems)
      : c_(c), jd_(c.joints[joint]), eds_(jd_.eds.get()), plan_(plan), problems_(problems) {
    plan_.joint = joint;
    plan_.node = jd_.node;
    plan_.eds_path = jd_.eds_path;
    plan_.torque_unit = jd_.torque_unit;
    key_ = "joint" + std::to_string(joint + 1) + ".";
  }

  void run() {
    if (eds_ != nullptr && eds_->node_id && *eds_->node_id != jd_.node) {
      problems_.push_back(key_ + "eds (" + jd_.eds_path + ") is a DCF commissioned for node " +
                          std::to_string(*eds_->node_id) + ", but " + key_ +
                          "node = " + std::to_string(jd_.node) + ": which node is the drive?");
    }
    // What the file's reader let pass (a malformed manufacturer object
    // left out, Latin-1 text) is the plan's warning.
    if (eds_ != nullptr)
      plan_.warnings.insert(plan_.warnings.end(), eds_->notes.begin(), eds_->notes.end());
    decide_feedback();
    identity();
    scaling();
    mode();
    cycle();
    limits();
    heartbeats();
    pdos();
  }

 private:
  // --- what the EDS says ---
  const co::EdsVariable* find(od::Object o) const {
    return eds_ == nullptr ? nullptr : eds_->find(o.index, o.subindex);
  }
  // Without an EDS the generic profile has every object the bring-up uses.
  bool has(od::Object o) const { return eds_ == nullptr || find(o) != nullptr; }
  bool readable(od::Object o) const {
    const co::EdsVariable* v = find(o);
    return eds_ == nullptr || (v != nullptr && !v->opaque && co::readable(v->access));
  }
  bool writable(od::Object o) const {
    const co::EdsVariable* v = find(o);
    return eds_ == nullptr || (v != nullptr && !v->opaque && co::writable(v->access));
  }
  bool mappable(od::Object o) const {
    const co::EdsVariable* v = find(o);
    return eds_ == nullptr || (v != nullptr && !v->opaque && v->pdo_mappable);
  }
  std::optional<std::uint64_t> value(od::Object o) const {
    const co::EdsVariable* v = find(o);
    if (v == nullptr || v->opaque) return std::nullopt;
    return v->value(jd_.node);
  }
  unsigned bits(od::Object o, unsigned generic) const {
    const co::EdsVariable* v = find(o);
    return v == nullptr ? generic : v->size_bytes() * 8;
  }
  // "joint2.eds (epos2.eds:1234)", the line where the EDS has the object.
  std::string where(od::Object o) const;
  // A problem with an object: missing, or as `state` says.
  void problem(od::Object o, const std::string& name, const std::string& why,
               const std::string& state = "") {
    const std::string what = object_text(o) + " (" + name + ")";
    problems_.push_back(where(o) + ": " +
                        (find(o) == nullptr ? "no object " + what : what + " " + state) + ": " +
                        why);
  }
  static std::string opaque_text(const co::EdsVariable& v) {
    return "is of data type " + hex(v.declared_type, 4) + ", which this file does not define";
  }
  // The object must be there and readable (writable): else a problem.
  bool need(od::Object o, bool write, const std::string& name, const std::string& why) {
    if (write ? writable(o) : readable(o)) return true;
    const co::EdsVariable* v = find(o);
    problem(o, name, why,
            v != nullptr && v->opaque ? opaque_text(*v)
            : write                   ? "is not writable"
                                      : "is not readable");
    return false;
  }

  // --- the plan's transfers ---
  void read(od::Object o, SdoCheck check, const std::string& what) {
    plan_.actions.push_back({o, 0, 0, check, what, ""});
  }
  void write(od::Object o, std::uint8_t size, std::uint32_t v, const std::string& what,
             const std::string& shown) {
    plan_.actions.push_back({o, size, v, SdoCheck::kNone, what, shown});
  }

  bool mapping_writable(PdoObjects which) const {
    return writable({which.mapping(), 0}) && writable({which.mapping(), 1});
  }
  PdoLayout default_layout(PdoObjects which) const;
  bool fixed(PdoObjects which) const {
    return has({which.mapping(), 0}) && !mapping_writable(which);
  }
  bool carries(PdoObjects which, const std::vector<Wanted>& wanted) const;
  bool own_use(unsigned n) const;
  std::optional<unsigned> fixed_pdo(bool receive, const std::vector<Wanted>& wanted,
                                    unsigned skip = 0) const;
  bool carried(od::Object o) const;
  std::optional<unsigned> free_id(bool receive, const std::vector<unsigned>& used);
  PdoObjects numbered(bool receive, unsigned n, std::vector<unsigned>& used);
  PdoObjects control_pdo(const std::vector<Wanted>& control);
  bool split_sample(const std::vector<Wanted>& sample);
  void decide_feedback();
  void identity();
  void scaling();
  void torque_unit_hint();
  void rated_value(od::Object o, SdoCheck check, const std::string& name, const std::string& key,
                   bool set, double configured, double to_drive);
  void mode();
  void cycle();
  void limits();
  void heartbeats();
  void pdos();
  void pdo(PlannedPdo& planned, PdoObjects which, const std::vector<Wanted>& wanted);
  void cob_id(PlannedPdo& planned, PdoObjects which);
  void fixed_layout(PlannedPdo& planned, PdoObjects which, const std::vector<Wanted>& wanted);
  void pdo_writes(const PlannedPdo& planned, PdoObjects which, bool cob_writable);
  void turn_off(PdoObjects which);
  void echo_last();
  void arm_pdo();

  const PortConfig& c_;
  const JointDrive& jd_;
  const co::Eds* eds_;
  DrivePlan& plan_;
  std::vector<std::string>& problems_;
  std::string key_;
  // The TPDOs (1 to 4) a split sample uses or whose COB-ID it took: not
  // turned off.
  std::vector<unsigned> tpdos_taken_;
  bool taken(unsigned n) const {
    return std::find(tpdos_taken_.begin(), tpdos_taken_.end(), n) != tpdos_taken_.end();
  }
};

bool controller_fills(std::uint32_t entry);

}  // namespace fw_linux::planning
