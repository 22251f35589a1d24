// CiA 301 SDO: the abort codes' texts and the block transfers' CRC.
#include "delta/can/sdo.hpp"

namespace delta::can::sdo {

namespace {

struct AbortText {
  AbortCode code;
  const char* text;
};

constexpr AbortText kAbortTexts[] = {
    {kAbortToggleBit, "toggle bit not alternated"},
    {kAbortTimeout, "SDO protocol timed out"},
    {kAbortCommand, "client/server command specifier not valid or unknown"},
    {kAbortBlockSize, "invalid block size"},
    {kAbortSequenceNumber, "invalid sequence number"},
    {kAbortCrc, "CRC error"},
    {kAbortOutOfMemory, "out of memory"},
    {kAbortUnsupportedAccess, "unsupported access to an object"},
    {kAbortWriteOnly, "attempt to read a write-only object"},
    {kAbortReadOnly, "attempt to write a read-only object"},
    {kAbortObjectDoesNotExist, "object does not exist in the object dictionary"},
    {kAbortNotMappable, "object cannot be mapped to the PDO"},
    {kAbortPdoLength,
     "the number and length of the objects to be mapped would exceed the PDO length"},
    {kAbortParameterIncompatible, "general parameter incompatibility"},
    {kAbortInternalIncompatible, "general internal incompatibility in the device"},
    {kAbortHardware, "access failed due to a hardware error"},
    {kAbortLengthMismatch, "data type does not match, length of service parameter does not match"},
    {kAbortLengthTooHigh, "data type does not match, length of service parameter too high"},
    {kAbortLengthTooLow, "data type does not match, length of service parameter too low"},
    {kAbortSubindexDoesNotExist, "sub-index does not exist"},
    {kAbortValueRange, "invalid value for parameter"},
    {kAbortValueTooHigh, "value of parameter written too high"},
    {kAbortValueTooLow, "value of parameter written too low"},
    {kAbortMaxBelowMin, "maximum value is less than minimum value"},
    {kAbortNoResource, "resource not available: SDO connection"},
    {kAbortGeneral, "general error"},
    {kAbortCannotStore, "data cannot be transferred or stored to the application"},
    {kAbortLocalControl,
     "data cannot be transferred or stored to the application because of local control"},
    {kAbortDeviceState,
     "data cannot be transferred or stored to the application because of the present device "
     "state"},
    {kAbortNoDictionary, "object dictionary dynamic generation failed or no object dictionary"},
    {kAbortNoData, "no data available"},
};

}  // namespace

const char* abort_meaning(AbortCode code) {
  for (const AbortText& t : kAbortTexts) {
    if (t.code == code) return t.text;
  }
  return "unknown abort code";
}

std::uint16_t crc16(std::uint16_t crc, std::span<const std::uint8_t> data) {
  for (const std::uint8_t byte : data) {
    crc = static_cast<std::uint16_t>(crc ^ (std::uint16_t{byte} << 8));
    for (int bit = 0; bit < 8; ++bit) {
      crc = static_cast<std::uint16_t>((crc & 0x8000) != 0 ? (crc << 1) ^ 0x1021 : crc << 1);
    }
  }
  return crc;
}

}  // namespace delta::can::sdo
