// The emulated drive's object dictionary: the table behind its SDO server.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <utility>

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
  static std::span<const DriveTable::Scalar> vendor_scalars();
  static std::span<const DriveTable::Text> texts();

 private:
  template <unsigned Pdo>
  static std::uint32_t cob_id_get(const DriveContext& c);
  template <unsigned Pdo>
  static delta::can::sdo::AbortCode cob_id_set(DriveContext& c, std::uint32_t v);
  template <unsigned Pdo>
  static std::uint32_t transmission_get(const DriveContext& c);
  template <unsigned Pdo>
  static delta::can::sdo::AbortCode transmission_set(DriveContext& c, std::uint32_t v);
  template <unsigned Pdo, std::size_t Sub>
  static std::uint32_t mapping_get(const DriveContext& c);
  template <unsigned Pdo, std::size_t Sub>
  static delta::can::sdo::AbortCode mapping_set(DriveContext& c, std::uint32_t v);
  template <unsigned Pdo, std::size_t... Sub>
  static auto mapping_objects(std::uint16_t index, std::index_sequence<Sub...>)
      -> std::array<DriveTable::Scalar, sizeof...(Sub)>;
};

}  // namespace emu
