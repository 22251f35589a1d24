// The identified model as the controller stores and transfers it: the
// `delta-model/3` record, 212 bytes, little-endian (docs/protocol.md,
// object 0x2200:1). `host_id model load` writes it, the controller checks it
// whole before it uses it, keeps it across restarts and gives it back on a
// read. Integer only: the firmware core's formats (delta/fixed/dynamics.hpp).
//
//   offset size
//     0     4   magic "DMDL"
//     4     2   format version, 3
//     6     1   kind: 1 delta, 2 lumped
//     7     1   flags: bit 0, the record carries collision thresholds
//     8     4   fit id (the CRC-32 of the result file it came from)
//    12    16   geometry it was fitted for: a, b, R, r, Q7.24 m
//    28   108   27 parameters, i32 each, in the order of kModelFields
//   136    36   collision thresholds, Q12.19 i32: base 1-3 (N m), per speed
//               1-3 (N m s/rad), per acceleration 1-3 (N m s^2/rad); 0
//               without flag bit 0
//   172    24   the drive train, Q1.30 i32: torque gain gap 1-3, load
//               friction 1-3 (0: none)
//   196    12   each gearbox's compliance 1/K, Q1.30 i32 rad/(N m), in
//               [0, 1/64) (0: rigid)
//   208     4   CRC-32 of bytes 0..207
//
// Older records are still read, as a controller keeps one from before:
// `delta-model/2` (version 2, 200 bytes: no compliances, the CRC at 196)
// and `delta-model/1` (version 1, 140 bytes: no flags, thresholds or drive
// train, the CRC at 136).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "delta/fixed/dynamics.hpp"

namespace delta::controller {

inline constexpr std::size_t kModelRecordBytes = 212;
inline constexpr std::size_t kModelRecordV2Bytes = 200;
inline constexpr std::size_t kModelRecordV1Bytes = 140;
using ModelRecordBytes = std::array<std::uint8_t, kModelRecordBytes>;
inline constexpr std::uint16_t kModelRecordVersion = 3;

struct ModelRecord {
  fx::GeometryQ geometry{};
  fx::ModelParametersQ parameters{};
  std::uint32_t fit_id{0};
  // The detector's thresholds the fit derived for this model; none in a
  // delta-model/1 record or a model fitted without them.
  bool has_collision_thresholds{false};
  fx::CollisionThresholdsQ collision_thresholds{};
};

// Why a record was refused (0: it was not). The controller shows the last
// load's verdict at 0x2200:4.
enum class ModelRecordFault : std::uint8_t {
  kOk = 0,
  kLength = 1,     // neither 212 (version 3), 200 (version 2) nor 140 (version 1) bytes
  kFormat = 2,     // not "DMDL", or another format version (or length)
  kChecksum = 3,   // the CRC-32 does not match: damaged on the way
  kKind = 4,       // neither delta nor lumped
  kValue = 5,      // a value out of range (a negative mass, inertia, friction, threshold or
                   // compliance; w, vs)
  kGeometry = 6,   // fitted for another geometry than the controller's
  kBusy = 7,       // a trajectory is running: models change between runs
  kNotStored = 8,  // the controller could not store it (it keeps the one it had)
  kDetector = 9,   // collision.detect = true: the detector needs the model and its thresholds
};

inline constexpr const char* model_record_fault_name(ModelRecordFault f) {
  switch (f) {
    case ModelRecordFault::kOk:
      return "ok";
    case ModelRecordFault::kLength:
      return "neither 212, 200 nor 140 bytes";
    case ModelRecordFault::kFormat:
      return "not a delta-model/3 (or /2, /1) record";
    case ModelRecordFault::kChecksum:
      return "CRC-32 mismatch (damaged on the way)";
    case ModelRecordFault::kKind:
      return "neither a delta nor a lumped model";
    case ModelRecordFault::kValue:
      return "a value out of range";
    case ModelRecordFault::kGeometry:
      return "fitted for another geometry";
    case ModelRecordFault::kBusy:
      return "a trajectory is running (models change between runs)";
    case ModelRecordFault::kNotStored:
      return "the controller could not store it";
    case ModelRecordFault::kDetector:
      return "collision.detect = true: the detector needs the identified model with its "
             "collision thresholds";
  }
  return "unknown";
}

void encode_model_record(const ModelRecord& r, ModelRecordBytes& out);

// Decodes and checks a record on its own (length, format, CRC, kind, every
// value's range); the geometry is the caller's to compare.
ModelRecordFault decode_model_record(std::span<const std::uint8_t> bytes, ModelRecord& out);

// Whether two geometries are the same robot: every length within 1 um
// (17 LSB of Q7.24), as the host's check.
bool same_geometry_q(const fx::GeometryQ& a, const fx::GeometryQ& b);

}  // namespace delta::controller
