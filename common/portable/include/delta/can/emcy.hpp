// What an emergency (EMCY) error code means: CiA 301's table of error codes
// (classes 0x00xx..0xFFxx and the communication codes 0x81xx/0x82xx), with
// the codes this product's drive profile adds. Portable: no heap, texts are
// static.
#pragma once

#include <cstdint>

namespace delta::can::od {

struct EmcyMeaning {
  std::uint16_t code;
  std::uint16_t mask;  // the bits of a code that must match `code`
  const char* text;
};

// Most specific first: the first entry that matches names a code.
inline constexpr EmcyMeaning kEmcyMeanings[] = {
    {0x0000, 0xFF00, "error reset or no error"},
    {0x1000, 0xFF00, "generic error"},
    {0x2310, 0xFFFF, "continuous over-current"},
    {0x2100, 0xFF00, "current, device input side"},
    {0x2200, 0xFF00, "current inside the device"},
    {0x2300, 0xFF00, "current, device output side"},
    {0x2000, 0xF000, "current"},
    {0x3100, 0xFF00, "mains voltage"},
    {0x3200, 0xFF00, "voltage inside the device"},
    {0x3300, 0xFF00, "output voltage"},
    {0x3000, 0xF000, "voltage"},
    {0x4100, 0xFF00, "ambient temperature"},
    {0x4200, 0xFF00, "device temperature"},
    {0x4000, 0xF000, "temperature"},
    {0x5000, 0xF000, "device hardware"},
    {0x6100, 0xFF00, "internal software"},
    {0x6200, 0xFF00, "user software"},
    {0x6300, 0xFF00, "data set"},
    {0x6000, 0xF000, "device software"},
    {0x7000, 0xF000, "additional modules"},
    {0x8110, 0xFFFF, "CAN overrun (objects lost)"},
    {0x8120, 0xFFFF, "CAN in error passive mode"},
    {0x8130, 0xFFFF, "life guard or heartbeat error"},
    {0x8140, 0xFFFF, "recovered from bus off"},
    {0x8150, 0xFFFF, "CAN-ID collision"},
    {0x8100, 0xFF00, "communication"},
    {0x8210, 0xFFF0, "PDO not processed due to length error"},
    {0x8220, 0xFFF0, "PDO length exceeded"},
    {0x8230, 0xFFFF, "DAM MPDO not processed, destination object not available"},
    {0x8240, 0xFFFF, "unexpected SYNC data length"},
    {0x8250, 0xFFF0, "RPDO timeout"},
    {0x8200, 0xFF00, "protocol error"},
    {0x8000, 0xF000, "monitoring"},
    {0x9000, 0xF000, "external error"},
    {0xF000, 0xFF00, "additional functions"},
    {0xFF00, 0xFF00, "device specific"},
};

// The meaning of `code`; "not a CiA 301 error code" for codes no entry has.
constexpr const char* emcy_meaning(std::uint16_t code) {
  for (const EmcyMeaning& m : kEmcyMeanings) {
    if ((code & m.mask) == m.code) return m.text;
  }
  return "not a CiA 301 error code";
}

}  // namespace delta::can::od
