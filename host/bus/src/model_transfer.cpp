#include "host_id/model_transfer.hpp"

#include <cstdio>
#include <ostream>
#include <vector>

#include "delta/can/sdo_channel.hpp"
#include "delta/controller/model_record.hpp"
#include "delta/model_q.hpp"
#include "delta/model_terms.hpp"

namespace host_id {

namespace {

namespace sdo = delta::can::sdo;
namespace mc = delta::controller;
constexpr std::uint16_t kModelObject = 0x2200;
constexpr int kExitAborted = 3;
constexpr int kExitNoAnswer = 4;

struct Channel {
  explicit Channel(const ModelLink& link)
      : node(static_cast<std::uint8_t>(link.node)),
        socket(delta::can::Socket::open(link.iface, {delta::can::sdo_response_filter(node)})),
        sdo(socket, node, std::chrono::milliseconds(link.timeout_ms)) {}
  std::uint8_t node;
  delta::can::Socket socket;
  delta::can::SdoChannel sdo;

  [[noreturn]] void fail(std::uint8_t sub, const delta::can::SdoOutcome& o,
                         const std::string& why = "") {
    throw ModelTransferError{sdo.describe(kModelObject, sub, o) + why,
                             o.by_server ? kExitAborted : kExitNoAnswer};
  }
  std::uint32_t read_u32(std::uint8_t sub) {
    std::vector<std::uint8_t> bytes;
    const auto o = sdo.upload(kModelObject, sub, bytes, sdo::Transfer::kAuto, 4);
    if (!o.ok()) fail(sub, o);
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < bytes.size() && i < 4; ++i) v |= std::uint32_t{bytes[i]} << (8 * i);
    return v;
  }
};

std::string fit_text(std::uint32_t id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%08X", id);
  return buf;
}

std::string reason_of(std::uint32_t fault) {
  const auto f = static_cast<mc::ModelRecordFault>(fault);
  std::string text = mc::model_record_fault_name(f);
  switch (f) {
    case mc::ModelRecordFault::kGeometry:
      return text + ": fit a log of this robot (its geometry is the controller's configuration)";
    case mc::ModelRecordFault::kBusy:
      return text + ": load it when the run has ended";
    case mc::ModelRecordFault::kChecksum:
      return text + ": try again";
    case mc::ModelRecordFault::kNotStored:
      return text + ": check feed_forward.store on the controller";
    case mc::ModelRecordFault::kDetector:
      return text +
             ": fit the log again with this host_id (it derives the thresholds), or set "
             "collision.threshold_Nm or collision.detect on the controller";
    default:
      return text;
  }
}

}  // namespace

void load_model(const ModelLink& link, const delta::IdentifiedModel& m) {
  if (!m.geometry) {
    throw ModelTransferError{
        "the result records no geometry (saved by an older host_id): fit again to save one", 2};
  }
  // Its own values first (the controller checks them again, and the geometry).
  const auto problems = delta::model_problems(m, *m.geometry);
  if (!problems.empty()) {
    std::string text = "the model cannot run on a controller:";
    for (const auto& p : problems) text += "\n  " + p;
    throw ModelTransferError{text, 2};
  }
  mc::ModelRecordBytes bytes{};
  mc::encode_model_record(delta::model_record(m), bytes);
  Channel c(link);
  const auto o = c.sdo.download(kModelObject, 1, bytes, sdo::Transfer::kAuto);
  if (!o.ok()) {
    std::string why;
    if (o.by_server) why = "; the controller says: " + reason_of(c.read_u32(4));
    c.fail(1, o, why);
  }
  const std::uint32_t in_use = c.read_u32(2);
  if (in_use != m.fit_id) {
    throw ModelTransferError{"the controller took the model but reports fit " + fit_text(in_use) +
                                 ", not " + fit_text(m.fit_id),
                             kExitAborted};
  }
}

ModelInUse read_model(const ModelLink& link) {
  Channel c(link);
  ModelInUse r;
  r.mode = static_cast<std::uint8_t>(c.read_u32(3));
  r.fit_id = c.read_u32(2);
  std::vector<std::uint8_t> bytes;
  const auto o = c.sdo.upload(kModelObject, 1, bytes, sdo::Transfer::kAuto, 4096);
  if (!o.ok()) {
    if (o.by_server && o.abort == sdo::kAbortNoData) return r;  // no model
    c.fail(1, o);
  }
  mc::ModelRecord record;
  const auto f = mc::decode_model_record(bytes, record);
  if (f != mc::ModelRecordFault::kOk) {
    throw ModelTransferError{
        "node " + std::to_string(link.node) +
            ": 0x2200:1 is not a valid model record: " + mc::model_record_fault_name(f),
        kExitAborted};
  }
  r.model = delta::identified_model(record);
  return r;
}

namespace {

// The collision detector's thresholds the model carries (docs/safety.md).
void print_collision_thresholds(const delta::IdentifiedModel& m, std::ostream& out) {
  if (!m.collision_thresholds) {
    out << "collision thresholds: none (the detector is off unless keys set them)\n";
    return;
  }
  const delta::CollisionThresholds& t = *m.collision_thresholds;
  out << "collision thresholds (docs/safety.md):\n";
  char line[160];
  const auto row = [&](const char* name, const delta::Joint3& v, const char* unit) {
    std::snprintf(line, sizeof line, "  %-24s %12.6g %12.6g %12.6g %s\n", name, v[0], v[1], v[2],
                  unit);
    out << line;
  };
  row("base", t.base_Nm, "N m");
  row("per_speed", t.per_speed_Nm_s_per_rad, "N m s/rad");
  row("per_acceleration", t.per_acceleration_Nm_s2_per_rad, "N m s^2/rad");
}

}  // namespace

void print_model(const ModelInUse& m, std::ostream& out) {
  static const char* const kModes[] = {"off", "nominal", "model"};
  out << "feed-forward: " << (m.mode < 3 ? kModes[m.mode] : "unknown") << "\n";
  if (!m.model) {
    out << "model: none loaded\n";
    return;
  }
  const delta::IdentifiedModel& id = *m.model;
  out << "model: " << id.kind << ", fit " << fit_text(m.fit_id) << "\n";
  out << "geometry: " << delta::describe_geometry(*id.geometry) << "\n";
  // Every parameter the model has, by the names host_id fit reports, per
  // joint (as the controller holds them).
  const auto terms =
      delta::physical_model_terms(id.kind, id.parameters.stribeck_velocity_rad_s > 0.0, true);
  char line[160];
  for (const delta::ModelTerm& t : terms) {
    if (t.robot_value != nullptr) {
      std::snprintf(line, sizeof line, "  %-24s %12.6g %s\n", t.name,
                    id.parameters.*(t.robot_value), t.unit);
      out << line;
      continue;
    }
    const delta::Joint3& v = id.parameters.*(t.joint_value);
    std::snprintf(line, sizeof line, "  %-24s %12.6g %12.6g %12.6g %s\n", t.name, v[0], v[1], v[2],
                  t.unit);
    out << line;
  }
  std::snprintf(line, sizeof line, "  %-24s %12.6g rad/s\n", "coulomb_smoothing",
                id.parameters.coulomb_smoothing_rad_s);
  out << line;
  if (id.parameters.stribeck_velocity_rad_s > 0.0) {
    std::snprintf(line, sizeof line, "  %-24s %12.6g rad/s\n", "stribeck_velocity",
                  id.parameters.stribeck_velocity_rad_s);
    out << line;
  }
  const delta::DriveTrainTerms& d = id.drive_train;
  if (d.torque_gain_gap != delta::Joint3{} || d.load_friction != delta::Joint3{}) {
    for (const auto& [name, v] : {std::pair{"torque_gain_gap", d.torque_gain_gap},
                                  std::pair{"load_friction", d.load_friction}}) {
      std::snprintf(line, sizeof line, "  %-24s %12.6g %12.6g %12.6g\n", name, v[0], v[1], v[2]);
      out << line;
    }
  }
  const delta::Joint3& c = id.gearbox_compliance_rad_per_Nm;
  if (c != delta::Joint3{}) {
    const auto stiffness = [](double v) { return v > 0.0 ? 1.0 / v : 0.0; };
    std::snprintf(line, sizeof line, "  %-24s %12.6g %12.6g %12.6g N m/rad", "gearbox_stiffness",
                  stiffness(c[0]), stiffness(c[1]), stiffness(c[2]));
    out << line << " (0: rigid; the controller compensates the deflection unless "
        << "feed_forward.deflection_compensation = false)\n";
  }
  print_collision_thresholds(id, out);
}

}  // namespace host_id
