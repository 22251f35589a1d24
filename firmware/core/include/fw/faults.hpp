// The firmware's fault codes: the controller's vocabulary in common/
// (delta/controller/vocabulary.hpp), which Modbus, CAN and docs/firmware.md
// report alike.
#pragma once

#include "delta/controller/vocabulary.hpp"

namespace fw {

using delta::controller::Fault;
using delta::controller::fault_name;

}  // namespace fw
