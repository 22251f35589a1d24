#include "delta/controller/model_record.hpp"

#include <type_traits>

#include "delta/little_endian.hpp"
#include "delta/update/crc32.hpp"

namespace delta::controller {

namespace {

constexpr std::uint8_t kMagic[4] = {'D', 'M', 'D', 'L'};
constexpr std::size_t kGeometryAt = 12;
constexpr std::size_t kParametersAt = 28;
constexpr std::size_t kThresholdsAt = 136;
constexpr std::size_t kDriveTrainAt = 172;
constexpr std::size_t kComplianceAt = 196;
constexpr std::size_t kCrcAt = 208;
constexpr std::uint8_t kHasThresholds = 0x01;
constexpr std::int32_t kMicrometreQ24 = 17;  // 1 um in Q7.24, rounded up

// The 27 parameters in record order, each with whether it must not be
// negative: the record's field list, written once for both directions.
template <class P, class Visit>
void each_field(P& p, Visit&& visit) {
  for (auto& v : p.arm_inertia_kg_m2) visit(v, true);
  for (auto& v : p.arm_gravity_cos_Nm) visit(v, true);
  for (auto& v : p.arm_gravity_sin_Nm) visit(v, false);
  visit(p.platform_inertial_mass_kg, true);
  visit(p.platform_weight_mass_kg, true);
  visit(p.forearm_coupling_kg, true);
  for (auto& v : p.viscous_friction_Nm_s_per_rad) visit(v, true);
  for (auto& v : p.coulomb_friction_Nm) visit(v, true);
  for (auto& v : p.stribeck_friction_Nm) visit(v, true);
  for (auto& v : p.torque_offset_Nm) visit(v, false);
  visit(p.coulomb_smoothing_rad_s, true);
  visit(p.stribeck_velocity_rad_s, true);
  visit(p.gravity_m_s2, true);
}

// The drive train's terms in record order (versions 2 and 3).
template <class P, class Visit>
void each_drive_train_field(P& p, Visit&& visit) {
  for (auto& v : p.torque_gain_gap) visit(v);
  for (auto& v : p.load_friction) visit(v);
}

// Within what the controller runs: |gap| < 1/2, load friction in [0, 1/2).
bool drive_train_in_range(const fx::ModelParametersQ& p) {
  constexpr std::int32_t kHalf = std::int32_t{1} << 29;  // 1/2 in Q1.30
  for (unsigned j = 0; j < 3; ++j) {
    const std::int32_t gap = p.torque_gain_gap[j].raw();
    const std::int32_t mu = p.load_friction[j].raw();
    if (gap <= -kHalf || gap >= kHalf || mu < 0 || mu >= kHalf) return false;
  }
  return true;
}

// The collision thresholds in record order (every one not negative).
template <class T, class Visit>
void each_threshold(T& t, Visit&& visit) {
  for (auto& v : t.base_Nm) visit(v);
  for (auto& v : t.per_speed_Nm_s_per_rad) visit(v);
  for (auto& v : t.per_acceleration_Nm_s2_per_rad) visit(v);
}

// The record's length for its format version; 0 for a version it does not
// have.
std::size_t length_of_version(std::uint16_t version) {
  if (version == 1) return kModelRecordV1Bytes;
  if (version == 2) return kModelRecordV2Bytes;
  if (version == kModelRecordVersion) return kModelRecordBytes;
  return 0;
}

// Within what the controller runs: 0 <= c < 1/64 rad/(N m) (a stiffness of
// 64 N m/rad at least, softer than any gearbox).
bool compliance_in_range(const fx::ModelParametersQ& p) {
  constexpr std::int32_t kLimit = std::int32_t{1} << 24;  // 1/64 in Q1.30
  for (const fx::Q1_30 c : p.gearbox_compliance_rad_per_Nm) {
    if (c.raw() < 0 || c.raw() >= kLimit) return false;
  }
  return true;
}

ModelRecordFault check_frame(std::span<const std::uint8_t> bytes) {
  if (bytes.size() != kModelRecordBytes && bytes.size() != kModelRecordV2Bytes &&
      bytes.size() != kModelRecordV1Bytes) {
    return ModelRecordFault::kLength;
  }
  for (std::size_t i = 0; i < 4; ++i) {
    if (bytes[i] != kMagic[i]) return ModelRecordFault::kFormat;
  }
  if (length_of_version(get_le16(bytes, 4)) != bytes.size()) return ModelRecordFault::kFormat;
  const std::size_t crc_at = bytes.size() - 4;
  if (get_le32(bytes, crc_at) != update::crc32(bytes.first(crc_at))) {
    return ModelRecordFault::kChecksum;
  }
  return ModelRecordFault::kOk;
}

// A version 2 or 3 record's thresholds; false for a negative one.
bool decode_thresholds(std::span<const std::uint8_t> bytes, ModelRecord& r) {
  if (bytes.size() == kModelRecordV1Bytes || (bytes[7] & kHasThresholds) == 0) return true;
  r.has_collision_thresholds = true;
  std::size_t at = kThresholdsAt;
  bool in_range = true;
  each_threshold(r.collision_thresholds, [&](fx::Q12_19& v) {
    v = fx::Q12_19::from_raw(static_cast<std::int32_t>(get_le32(bytes, at)));
    at += 4;
    if (v.raw() < 0) in_range = false;
  });
  return in_range;
}

}  // namespace

void encode_model_record(const ModelRecord& r, ModelRecordBytes& out) {
  out = {};
  for (std::size_t i = 0; i < 4; ++i) out[i] = kMagic[i];
  put_le16(out, 4, kModelRecordVersion);
  out[6] = static_cast<std::uint8_t>(r.parameters.kind);
  put_le32(out, 8, r.fit_id);
  const fx::Q7_24 lengths[4] = {r.geometry.upper_arm_length_m, r.geometry.forearm_length_m,
                                r.geometry.base_radius_m, r.geometry.platform_radius_m};
  for (std::size_t i = 0; i < 4; ++i) {
    put_le32(out, kGeometryAt + 4 * i, static_cast<std::uint32_t>(lengths[i].raw()));
  }
  std::size_t at = kParametersAt;
  each_field(r.parameters, [&](const auto& v, bool) {
    put_le32(out, at, static_cast<std::uint32_t>(v.raw()));
    at += 4;
  });
  at = kDriveTrainAt;
  each_drive_train_field(r.parameters, [&](const fx::Q1_30& v) {
    put_le32(out, at, static_cast<std::uint32_t>(v.raw()));
    at += 4;
  });
  at = kComplianceAt;
  for (const fx::Q1_30 c : r.parameters.gearbox_compliance_rad_per_Nm) {
    put_le32(out, at, static_cast<std::uint32_t>(c.raw()));
    at += 4;
  }
  if (r.has_collision_thresholds) {
    out[7] = kHasThresholds;
    at = kThresholdsAt;
    each_threshold(r.collision_thresholds, [&](const fx::Q12_19& v) {
      put_le32(out, at, static_cast<std::uint32_t>(v.raw()));
      at += 4;
    });
  }
  put_le32(out, kCrcAt, update::crc32(std::span<const std::uint8_t>(out.data(), kCrcAt)));
}

ModelRecordFault decode_model_record(std::span<const std::uint8_t> bytes, ModelRecord& out) {
  const ModelRecordFault frame = check_frame(bytes);
  if (frame != ModelRecordFault::kOk) return frame;
  ModelRecord r;
  const std::uint8_t kind = bytes[6];
  if (kind != static_cast<std::uint8_t>(fx::ModelKind::kDelta) &&
      kind != static_cast<std::uint8_t>(fx::ModelKind::kLumped)) {
    return ModelRecordFault::kKind;
  }
  r.parameters.kind = static_cast<fx::ModelKind>(kind);
  r.fit_id = get_le32(bytes, 8);
  const auto length = [&](std::size_t i) {
    return fx::Q7_24::from_raw(static_cast<std::int32_t>(get_le32(bytes, kGeometryAt + 4 * i)));
  };
  r.geometry = {length(0), length(1), length(2), length(3)};
  std::size_t at = kParametersAt;
  bool in_range = true;
  each_field(r.parameters, [&](auto& v, bool nonnegative) {
    using Q = std::remove_reference_t<decltype(v)>;
    v = Q::from_raw(static_cast<std::int32_t>(get_le32(bytes, at)));
    at += 4;
    if (nonnegative && v.raw() < 0) in_range = false;
  });
  if (!decode_thresholds(bytes, r)) in_range = false;
  if (bytes.size() != kModelRecordV1Bytes) {
    at = kDriveTrainAt;
    each_drive_train_field(r.parameters, [&](fx::Q1_30& v) {
      v = fx::Q1_30::from_raw(static_cast<std::int32_t>(get_le32(bytes, at)));
      at += 4;
    });
    if (!drive_train_in_range(r.parameters)) in_range = false;
  }
  if (bytes.size() == kModelRecordBytes) {
    at = kComplianceAt;
    for (fx::Q1_30& c : r.parameters.gearbox_compliance_rad_per_Nm) {
      c = fx::Q1_30::from_raw(static_cast<std::int32_t>(get_le32(bytes, at)));
      at += 4;
    }
    if (!compliance_in_range(r.parameters)) in_range = false;
  }
  const fx::ModelParametersQ& p = r.parameters;
  if (!in_range || p.coulomb_smoothing_rad_s < fx::kMinFrictionVelocity ||
      (p.stribeck_velocity_rad_s.raw() != 0 &&
       p.stribeck_velocity_rad_s < fx::kMinFrictionVelocity)) {
    return ModelRecordFault::kValue;
  }
  out = r;
  return ModelRecordFault::kOk;
}

bool same_geometry_q(const fx::GeometryQ& a, const fx::GeometryQ& b) {
  const auto near = [](fx::Q7_24 x, fx::Q7_24 y) {
    const std::int64_t d = std::int64_t{x.raw()} - y.raw();
    return d <= kMicrometreQ24 && d >= -kMicrometreQ24;
  };
  return near(a.upper_arm_length_m, b.upper_arm_length_m) &&
         near(a.forearm_length_m, b.forearm_length_m) && near(a.base_radius_m, b.base_radius_m) &&
         near(a.platform_radius_m, b.platform_radius_m);
}

}  // namespace delta::controller
