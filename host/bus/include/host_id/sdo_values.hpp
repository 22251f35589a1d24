// The values of host_id sdo: an object's address as written on the command
// line, and a value's bytes by its type (CiA 301, little-endian).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace host_id {

struct Multiplexer {
  std::uint16_t index;
  std::uint8_t subindex;
};

// "0x1018:1", "1018:0x01", "0x6041": the index in hexadecimal (as CANopen
// writes it), the sub-index decimal or 0x hexadecimal, 0 when absent.
// delta::InputError names the text and the form expected.
Multiplexer parse_object(const std::string& text);

// The types a value may be given or read as: u8, u16, u32, i8, i16, i32,
// str, hex; delta::InputError for another.
void check_value_type(const std::string& type_name);

// The value to write as its little-endian bytes; delta::InputError when the
// text is not one of the type (out of range, not hexadecimal bytes).
std::vector<std::uint8_t> encode_value(const std::string& type_name, const std::string& text);

// What was read, as the type says ("auto": a number up to 4 bytes, text
// when printable, else bytes); delta::InputError when the bytes are not
// that type's size.
std::string decode_value(const std::string& type_name, const std::vector<std::uint8_t>& bytes);

}  // namespace host_id
