// The emulated drive's object dictionary behind its SDO server.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "delta/can/sdo.hpp"
#include "emu/emulator.hpp"

namespace emu {

class Emulator::DriveObjects final : public delta::can::sdo::ObjectDictionary {
 public:
  DriveObjects(Emulator& emulator, Drive& drive);

  delta::can::sdo::AbortCode find(std::uint16_t index, std::uint8_t subindex,
                                  delta::can::sdo::ObjectInfo& info) override;
  delta::can::sdo::AbortCode read(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                                  std::span<std::uint8_t> out) override;
  delta::can::sdo::AbortCode write(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                                   std::span<const std::uint8_t> data, bool last) override;

  // Where `eds` and these objects disagree, in words; "" if they agree.
  static std::string mismatch(DriveObjects& drive, const delta::canopen::Eds& eds);

 private:
  // A scalar object: its size, how to read it, and how to write it
  // (nullptr: read-only) with the value's checks.
  struct Object {
    std::uint16_t index;
    std::uint8_t subindex;
    std::uint8_t size;  // bytes
    std::uint32_t (*get)(const Emulator&, const Drive&);
    delta::can::sdo::AbortCode (*set)(Emulator&, Drive&, std::uint32_t);
  };
  static std::span<const Object> objects();
  static const Object* lookup(std::uint16_t index, std::uint8_t subindex,
                              delta::can::sdo::AbortCode& code);

  Emulator& emulator_;
  Drive& drive_;
  std::uint32_t staged_{0};  // a download's bytes until its last piece
};

}  // namespace emu
