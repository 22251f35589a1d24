#include "fw_linux/drive_plan.hpp"

#include <cstdio>
#include <sstream>

#include "bus_ids.hpp"
#include "drive_planner.hpp"

namespace fw_linux {

namespace od = delta::can::od;

unsigned PdoLayout::bytes() const {
  unsigned bits = 0;
  for (unsigned i = 0; i < count; ++i) bits += entries[i] & 0xFF;
  return bits / 8;
}

int PdoLayout::offset_of(od::Object object) const {
  unsigned bits = 0;
  const std::uint32_t key = std::uint32_t{object.index} << 16 | std::uint32_t{object.subindex} << 8;
  for (unsigned i = 0; i < count; ++i) {
    if ((entries[i] & 0xFFFFFF00u) == key) return static_cast<int>(bits / 8);
    bits += entries[i] & 0xFF;
  }
  return -1;
}

namespace planning {

std::string hex(std::uint32_t v, int digits) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%0*X", digits, v);
  return b;
}

}  // namespace planning

namespace {

using planning::hex;

std::string layout_text(const PlannedPdo& pdo) {
  std::string text;
  for (unsigned i = 0; i < pdo.layout.count; ++i) {
    const std::uint32_t e = pdo.layout.entries[i];
    text += (i ? ", " : "") +
            object_text({static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>(e >> 8)}) +
            " (" + std::to_string(e & 0xFF) + " bits)";
  }
  return text + (pdo.mapping_written ? "; mapping written" : "; the drive's fixed mapping");
}

std::string rated_text(std::uint32_t fixed, const char* object, const char* unit) {
  return fixed != 0
             ? std::to_string(fixed) + " " + unit + " (configured; the drive has no " + object + ")"
             : std::string("read from ") + object;
}

}  // namespace

std::string describe_plan(const DrivePlan& plan) {
  std::ostringstream out;
  out << "joint" << plan.joint + 1 << ": node " << int{plan.node} << ", "
      << (plan.eds_path.empty() ? "the generic CiA 402 profile (no jointN.eds)" : plan.eds_path)
      << "\n";
  const bool cst = plan.mode == delta::can::cia402::kModeCyclicSynchronousTorque;
  out << "  mode:     " << int{plan.mode}
      << (cst ? " (cyclic synchronous torque): " : " (profile torque): ") << plan.mode_reason
      << "\n";
  const char* unit = plan.torque_unit == TorqueUnit::kMilliamp           ? "mA"
                     : plan.torque_unit == TorqueUnit::kMilliNewtonMetre ? "mN m"
                                                                         : "per mille";
  if (plan.feedback == Feedback::kCurrent) {
    out << "  feedback: 0x6078 current actual value, per mille of the rated current, "
        << rated_text(plan.rated_current_mA, "0x6075", "mA") << "\n";
  } else {
    out << "  feedback: 0x6077 torque actual value, " << unit << "\n";
  }
  out << "  torque:   0x6071 target torque, " << unit;
  if (plan.torque_unit == TorqueUnit::kPerMille) {
    out << " of the rated torque, " << rated_text(plan.rated_torque_mNm, "0x6076", "mN m");
  }
  out << "\n  cycle:    " << plan.cycle << "\n";
  const std::pair<const PlannedPdo*, const char*> pdos[] = {
      {&plan.rpdo, "RPDO"},     {&plan.sample, "TPDO"}, {&plan.sample_rest, "TPDO"},
      {&plan.velocity, "TPDO"}, {&plan.echo, "TPDO"},   {&plan.arm, "TPDO"}};
  for (const auto& [pdo, kind] : pdos) {
    if (!pdo->used) continue;
    out << "  " << kind << pdo->number << ":    COB-ID " << hex(pdo->cob_id, 3);
    if (std::string(kind) == "TPDO") out << ", transmission type " << int{pdo->transmission_type};
    out << ": " << layout_text(*pdo) << "\n";
  }
  out << "  SDO transfers (" << plan.actions.size() << "):\n";
  for (const SdoAction& a : plan.actions) {
    out << "    " << (a.size == 0 ? "read  " : "write ") << object_text(a.object) << "  " << a.what;
    if (a.size != 0) out << " = " << a.shown;
    out << "\n";
  }
  for (const std::string& w : plan.warnings) out << "  warning: " << w << "\n";
  return out.str();
}

std::string object_text(od::Object o) {
  return hex(o.index, 4) + ":" + hex(o.subindex, 2).substr(2);
}

DrivePlans plan_drives(const PortConfig& c) {
  DrivePlans plans;
  for (unsigned j = 0; j < 3; ++j) planning::Planner(c, j, plans.drives[j], plans.problems).run();
  planning::check_bus_ids(plans, plans.problems);
  return plans;
}

}  // namespace fw_linux
