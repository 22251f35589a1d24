// The emulated drive's object dictionary: the table behind its SDO server.
#pragma once

#include <span>

#include "delta/canopen/object_table.hpp"
#include "emu/emulator.hpp"

namespace emu {

// What a drive's objects read and write: the emulator and the drive.
struct Emulator::DriveContext {
  Emulator& e;
  Drive& d;
};

class Emulator::DriveObjects {
 public:
  static std::span<const DriveTable::Scalar> scalars();
  static std::span<const DriveTable::Text> texts();
};

}  // namespace emu
