// host_id sdo's values: an object's address as typed, and a value's bytes
// by its type, both ways; every refusal says what was expected.
#include "host_id/sdo_values.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "delta/input_error.hpp"

namespace host_id {
namespace {

std::string error_of(void (*f)()) {
  try {
    f();
  } catch (const delta::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(SdoValuesTest, AnObjectIsAHexadecimalIndexAndADecimalOrHexSubIndex) {
  const Multiplexer a = parse_object("0x1018:1");
  EXPECT_EQ(a.index, 0x1018);
  EXPECT_EQ(a.subindex, 1);
  const Multiplexer b = parse_object("1A00:0x03");
  EXPECT_EQ(b.index, 0x1A00);
  EXPECT_EQ(b.subindex, 3);
  EXPECT_EQ(parse_object("6041").subindex, 0);
  for (const char* bad : {"", "0x10000", "1018:256", "1018:", "x1018", "1018:1a"}) {
    try {
      (void)parse_object(bad);
      ADD_FAILURE() << bad << " was taken";
    } catch (const delta::InputError& e) {
      EXPECT_EQ(std::string(e.what()),
                "sdo: object '" + std::string(bad) + "': expected INDEX[:SUB], e.g. 0x1018:1");
    }
  }
}

TEST(SdoValuesTest, NumbersAreLittleEndianWithinTheirTypesRange) {
  EXPECT_EQ(encode_value("u16", "0x1234"), (std::vector<std::uint8_t>{0x34, 0x12}));
  EXPECT_EQ(encode_value("i32", "-2"), (std::vector<std::uint8_t>{0xFE, 0xFF, 0xFF, 0xFF}));
  EXPECT_EQ(encode_value("hex", "01 a2:FF"), (std::vector<std::uint8_t>{0x01, 0xA2, 0xFF}));
  EXPECT_EQ(encode_value("str", "ab"), (std::vector<std::uint8_t>{'a', 'b'}));
  EXPECT_EQ(error_of([] { (void)encode_value("u8", "256"); }), "sdo: '256' is not a u8 (0 to 255)");
  EXPECT_EQ(error_of([] { (void)encode_value("i8", "-129"); }),
            "sdo: '-129' is not a i8 (-128 to 127)");
  EXPECT_EQ(error_of([] { (void)encode_value("hex", "1"); }),
            "sdo: '1' is not hexadecimal bytes (e.g. 01 A2 FF)");
  EXPECT_EQ(error_of([] { check_value_type("u64"); }),
            "sdo: --type u64: expected u8, u16, u32, i8, i16, i32, str or hex");
}

TEST(SdoValuesTest, WhatIsReadIsShownAsItsTypeOrAsItLooks) {
  EXPECT_EQ(decode_value("i16", {0xFE, 0xFF}), "-2 (0xFFFE)");
  EXPECT_EQ(decode_value("auto", {0x17, 0xDE, 0x00, 0x00}), "56855 (0x0000DE17)");
  EXPECT_EQ(decode_value("auto", {'d', 'e', 'l', 't', 'a', '_', 'f', 'w'}), "delta_fw");
  EXPECT_EQ(decode_value("auto", {0x01, 0x02, 0x03}), "01 02 03");  // 24 bits: bytes
  EXPECT_EQ(decode_value("auto", {'a', 'b', 'c'}), "61 62 63");
  EXPECT_EQ(decode_value("auto", {}), "");
  EXPECT_EQ(decode_value("auto", {0x00, 0x01, 0x02, 0x03, 0x04}), "00 01 02 03 04");
  EXPECT_EQ(error_of([] {
              (void)decode_value("u32", {0x01, 0x02});
            }),
            "sdo: the object has 2 bytes, not a u32 (01 02)");
}

}  // namespace
}  // namespace host_id
