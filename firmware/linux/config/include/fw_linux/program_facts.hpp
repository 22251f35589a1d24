// What a running delta_fw is: its version (0x1018:3, 0x100A, the Modbus
// version registers) and, when delta_boot started it after rolling a new
// program back, why (EMCY 0x6200, 0x2F00:2, Modbus update_rollback).
#pragma once

#include "delta/update/image.hpp"
#include "fw/update/slots.hpp"

namespace fw_linux {

struct ProgramFacts {
  delta::update::Version version{};
  fw::update::RevertReason rolled_back{fw::update::RevertReason::kNone};
};

}  // namespace fw_linux
