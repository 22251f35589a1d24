// The controller's identified model over the bus (docs/protocol.md, node
// 16's 0x2200): `host_id model load` writes a saved fit as a delta-model/1
// record (checked here first, then whole by the controller, which applies it
// between runs and keeps it), `host_id model show` reads what is in use.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>

#include "delta/identified_model.hpp"

namespace host_id {

struct ModelLink {
  std::string iface;
  int node{16};
  int timeout_ms{1000};
};

// A step that failed: its message and exit status (kExitSdoAborted: the
// controller refused, with its reason; kExitNoAnswer: no answer).
struct ModelTransferError {
  std::string message;
  int exit_code;
};

// Writes m to the controller and reads back the fit id in use. Throws
// ModelTransferError (the message names the SDO abort code and the
// controller's reason, 0x2200:4, and what to do).
void load_model(const ModelLink& link, const delta::IdentifiedModel& m);

struct ModelInUse {
  std::uint8_t mode{0};  // 0 off, 1 nominal, 2 model
  std::uint32_t fit_id{0};
  std::optional<delta::IdentifiedModel> model;  // none loaded or configured
};
ModelInUse read_model(const ModelLink& link);

// What `host_id model show` prints: mode, kind, fit id, geometry and every
// parameter in SI units as the controller holds them.
void print_model(const ModelInUse& m, std::ostream& out);

}  // namespace host_id
