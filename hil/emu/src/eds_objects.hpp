// A drive's object dictionary as its EDS describes it (delta_drive_emu
// --eds): exactly the EDS's objects, each with its access type and size.
// An object the emulator gives a behaviour (the built-in tables) is read
// and written there; any other keeps its value, starting from the EDS's
// default. Anything else is refused with its CiA 301 abort code.
#pragma once

#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "delta/can/sdo.hpp"
#include "delta/canopen/eds.hpp"

namespace emu {

class EdsObjects final : public delta::can::sdo::ObjectDictionary {
 public:
  // `behaviours`: the dictionaries with an emulated behaviour, asked in
  // order; they outlive this.
  EdsObjects(const delta::canopen::Eds& eds, std::uint8_t node,
             std::vector<delta::can::sdo::ObjectDictionary*> behaviours);

  delta::can::sdo::AbortCode find(std::uint16_t index, std::uint8_t subindex,
                                  delta::can::sdo::ObjectInfo& info) override;
  delta::can::sdo::AbortCode read(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                                  std::span<std::uint8_t> out) override;
  delta::can::sdo::AbortCode write(std::uint16_t index, std::uint8_t subindex, std::uint32_t offset,
                                   std::span<const std::uint8_t> data, bool last) override;
  void download_abandoned(std::uint16_t index, std::uint8_t subindex) override;

  bool mappable(std::uint16_t index, std::uint8_t subindex) const;
  // How many of the EDS's objects have an emulated behaviour.
  std::size_t behaviour_count() const { return behaviour_.size(); }
  // The EDS's defaults into the objects with a behaviour that takes them
  // (PDO objects aside: product_of() gives those), as at power-on.
  void apply_defaults();

 private:
  using Key = std::pair<std::uint16_t, std::uint8_t>;
  const delta::canopen::EdsVariable* variable(std::uint16_t index, std::uint8_t subindex,
                                              delta::can::sdo::AbortCode& code) const;

  const delta::canopen::Eds& eds_;
  std::uint8_t node_;
  std::map<Key, delta::can::sdo::ObjectDictionary*> behaviour_;
  std::map<Key, std::vector<std::uint8_t>> stored_;  // the others' values
  std::vector<std::uint8_t> staged_;                 // a download into a stored value
};

}  // namespace emu
