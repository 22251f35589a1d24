// A CiA 306 electronic data sheet (EDS): the device's identity and its
// object dictionary (objects, sub-indices, data types, access, defaults,
// PDO mapping). Read with inih (Debian's libinih); every error names the
// file and line. docs/protocol.md lists what is read.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace delta::canopen {

// "FILE:LINE: what is wrong".
class EdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Access : std::uint8_t {
  kReadOnly,
  kWriteOnly,
  kReadWrite,
  kReadWriteRead,
  kReadWriteWrite,
  kConst
};

constexpr bool readable(Access a) {
  return a != Access::kWriteOnly;
}
constexpr bool writable(Access a) {
  return a == Access::kWriteOnly || a == Access::kReadWrite || a == Access::kReadWriteRead ||
         a == Access::kReadWriteWrite;
}

// CiA 301 data types (DataType=0x....).
namespace data_type {
inline constexpr std::uint16_t kBoolean = 0x0001;
inline constexpr std::uint16_t kInteger8 = 0x0002;
inline constexpr std::uint16_t kInteger16 = 0x0003;
inline constexpr std::uint16_t kInteger32 = 0x0004;
inline constexpr std::uint16_t kUnsigned8 = 0x0005;
inline constexpr std::uint16_t kUnsigned16 = 0x0006;
inline constexpr std::uint16_t kUnsigned32 = 0x0007;
inline constexpr std::uint16_t kReal32 = 0x0008;
inline constexpr std::uint16_t kVisibleString = 0x0009;
inline constexpr std::uint16_t kOctetString = 0x000A;
inline constexpr std::uint16_t kUnicodeString = 0x000B;
inline constexpr std::uint16_t kDomain = 0x000F;
inline constexpr std::uint16_t kReal64 = 0x0011;
inline constexpr std::uint16_t kInteger64 = 0x0015;
inline constexpr std::uint16_t kUnsigned64 = 0x001B;
}  // namespace data_type

// The size in bytes of a basic data type; 0 for strings and domains (any
// length); nullopt for a type this reader does not know.
std::optional<std::uint32_t> data_type_size(std::uint16_t type);
bool data_type_signed(std::uint16_t type);
std::string_view data_type_name(std::uint16_t type);

// One variable: an object of type VAR, or a sub-index of an ARRAY/RECORD.
struct EdsVariable {
  std::uint16_t index{0};
  std::uint8_t subindex{0};
  std::string name;
  // A CiA 301 basic type; a manufacturer's DEFTYPE of one is resolved to it
  // (declared_type keeps the file's code). A type this file does not define
  // (a DEFSTRUCT, an unknown code) leaves the variable opaque: kept, its
  // size unknown (0), and a note in Eds::notes.
  std::uint16_t data_type{0};
  std::uint16_t declared_type{0};
  bool opaque{false};
  Access access{Access::kReadOnly};
  bool pdo_mappable{false};
  // DefaultValue as written; "$NODEID+..." is resolved by default_value().
  std::string default_text;
  // A DCF's ParameterValue (the value configured for the device), if any.
  std::string parameter_text;
  int line{0};  // of its section header, for messages

  std::uint32_t size_bytes() const { return opaque ? 0 : data_type_size(data_type).value_or(0); }
  // The default as the object's bit pattern (integers two's complement),
  // for node `node_id`; nullopt when none is given or it is a string.
  std::optional<std::uint64_t> default_value(std::uint8_t node_id) const;
  // The value the device has: a DCF's ParameterValue over the DefaultValue.
  std::optional<std::uint64_t> value(std::uint8_t node_id) const;
};

// [DeviceInfo]'s identity; a number the file does not give is unknown, and
// only the known ones are checked against a device.
struct EdsIdentity {
  std::optional<std::uint32_t> vendor_id;
  std::optional<std::uint32_t> product_code;
  std::optional<std::uint32_t> revision;
  std::string vendor_name;
  std::string product_name;
};

// A key of the file as written, and its line.
struct EdsKey {
  std::string text;
  int line{0};
};

// An object as an object list names it.
struct EdsListing {
  std::uint16_t index{0};
  std::string list;  // "MandatoryObjects", "OptionalObjects" or "ManufacturerObjects"
  int line{0};
};

struct Eds {
  std::string path;
  EdsIdentity identity;
  // A DCF ([DeviceComissioning]): its NodeID where given.
  bool dcf{false};
  std::optional<std::uint8_t> node_id;
  // What the reader accepted but a user may want to know ("PATH:LINE:
  // ..."): opaque types, Latin-1 text.
  std::vector<std::string> notes;
  std::map<std::pair<std::uint16_t, std::uint8_t>, EdsVariable> variables;
  // What the completeness check reads (check_eds_complete): [DeviceInfo]'s
  // keys (lower case), [DummyUsage]'s, every object the lists name, and
  // every object section ([XXXX], four hexadecimal digits) with its line.
  std::map<std::string, EdsKey> device_info;
  int device_info_line{0};
  std::map<std::string, EdsKey> dummy_usage;
  std::vector<EdsListing> listed;
  std::map<std::uint16_t, int> object_sections;

  const EdsVariable* find(std::uint16_t index, std::uint8_t subindex) const;
  bool has_object(std::uint16_t index) const;
};

// Reads and checks an EDS or a DCF (CiA 306), UTF-8 or Latin-1 text;
// throws EdsError ("PATH:LINE: ...").
Eds read_eds(const std::string& path);
// The same from text; `name` stands for the file in messages.
Eds parse_eds(std::string_view text, const std::string& name);

// Where an EDS is not complete and consistent by CiA 306 and 301, beyond
// what read_eds refuses: [DeviceInfo]'s keys (the baud rates, the
// granularity, the PDO counts), object sections that no list names or
// that sit in the wrong list, PDO communication objects without their
// mapping objects (and the reverse), mapping entries that name no
// mappable object or the wrong length, and sub-index 0 of a mapping or
// communication object against its sub-indices. Each finding is
// "PATH:LINE: what"; none for a complete EDS. For the EDS files the
// project ships.
std::vector<std::string> check_eds_complete(const Eds& eds);

// An EDS number: decimal, 0x hexadecimal or 0-prefixed octal (CiA 306),
// optionally "$NODEID+" before it. nullopt if it is not one.
std::optional<std::int64_t> parse_eds_number(std::string_view text, std::uint8_t node_id);

}  // namespace delta::canopen
