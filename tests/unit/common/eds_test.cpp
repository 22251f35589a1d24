// The EDS reader (delta/canopen/eds.hpp): the product's own EDS files, a
// hand-written one with every construct, and malformed files, each refused
// with its file:line and what is wrong.
#include "delta/canopen/eds.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

namespace delta::canopen {
namespace {

const std::string kHeader = R"([DeviceInfo]
VendorNumber=0x000000AB
ProductNumber=1234
RevisionNumber=0x00020003
VendorName=Example
ProductName=Example drive

[MandatoryObjects]
SupportedObjects=3
1=0x1000
2=0x1001
3=0x1018

[1000]
ParameterName=Device type
DataType=0x0007
AccessType=ro
DefaultValue=0x00020192

[1001]
ParameterName=Error register
ObjectType=0x7
DataType=0x0005
AccessType=ro
PDOMapping=1

[1018]
ParameterName=Identity
ObjectType=0x9
SubNumber=2

[1018sub0]
ParameterName=Highest sub-index
DataType=0x0005
AccessType=ro
DefaultValue=1

[1018sub1]
ParameterName=Vendor-ID
DataType=0x0007
AccessType=ro
DefaultValue=0x000000AB
)";

// The message of the error `text` raises, or "" if it is accepted.
std::string error_of(const std::string& text) {
  try {
    parse_eds(text, "drive.eds");
  } catch (const EdsError& e) {
    return e.what();
  }
  return "";
}

// TPDO1's communication object, target torque and the device name, each
// with what a reader must take from it (types, access, defaults, mapping).
const char* const kTpdoTorqueAndNameObjects = R"(
[OptionalObjects]
SupportedObjects=3
1=0x1800
2=0x6071
3=0x1008

[1800]
ParameterName=TPDO1 communication
ObjectType=0x9
SubNumber=2

[1800sub0]
ParameterName=Highest sub-index
DataType=0x0005
AccessType=const
DefaultValue=1

[1800sub1]
ParameterName=COB-ID
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x180

[6071]
ParameterName=Target torque
DataType=0x0003
AccessType=rww
PDOMapping=1
DefaultValue=-100
LowLimit=-1000

[1008]
ParameterName=Device name
DataType=0x0009
AccessType=const
DefaultValue=Example drive ; a comment
)";

TEST(EdsTest, ReadsIdentityObjectsTypesAccessDefaultsAndMapping) {
  const Eds eds = parse_eds(kHeader + kTpdoTorqueAndNameObjects, "drive.eds");
  EXPECT_EQ(eds.identity.vendor_id, 0xABu);
  EXPECT_EQ(eds.identity.product_code, 1234u);
  EXPECT_EQ(eds.identity.revision, 0x00020003u);
  EXPECT_EQ(eds.identity.product_name, "Example drive");
  EXPECT_EQ(eds.variables.size(), 8u);
  const EdsVariable* cob = eds.find(0x1800, 1);
  ASSERT_NE(cob, nullptr);
  EXPECT_EQ(cob->default_value(5), 0x185u);
  EXPECT_TRUE(writable(cob->access));
  EXPECT_EQ(cob->size_bytes(), 4u);
  const EdsVariable* torque = eds.find(0x6071, 0);
  ASSERT_NE(torque, nullptr);
  EXPECT_TRUE(torque->pdo_mappable);
  EXPECT_EQ(torque->size_bytes(), 2u);
  EXPECT_EQ(torque->default_value(1), 0xFF9Cu);  // -100 as INTEGER16
  EXPECT_FALSE(eds.find(0x1001, 0)->default_value(1).has_value());
  EXPECT_TRUE(eds.find(0x1001, 0)->pdo_mappable);
  EXPECT_FALSE(writable(eds.find(0x1008, 0)->access));
  EXPECT_EQ(eds.find(0x1008, 0)->default_text, "Example drive");
  EXPECT_EQ(eds.find(0x1008, 0)->size_bytes(), 0u);
  EXPECT_EQ(eds.find(0x1800, 2), nullptr);
  EXPECT_TRUE(eds.has_object(0x1018));
  EXPECT_FALSE(eds.has_object(0x1017));
}

TEST(EdsTest, NumbersAreDecimalHexOctalAndNodeRelative) {
  EXPECT_EQ(parse_eds_number("42", 0), 42);
  EXPECT_EQ(parse_eds_number(" 0x2A ", 0), 42);
  EXPECT_EQ(parse_eds_number("052", 0), 42);
  EXPECT_EQ(parse_eds_number("-7", 0), -7);
  EXPECT_EQ(parse_eds_number("$NODEID+0x200", 3), 0x203);
  EXPECT_EQ(parse_eds_number("0x200+$NODEID", 3), 0x203);
  EXPECT_EQ(parse_eds_number("$NODEID", 9), 9);
  EXPECT_FALSE(parse_eds_number("0x", 0));
  EXPECT_FALSE(parse_eds_number("12a", 0));
  EXPECT_FALSE(parse_eds_number("09", 0));  // not octal
  EXPECT_FALSE(parse_eds_number("$NODEID-1", 0));
  EXPECT_FALSE(parse_eds_number("", 0));
}

TEST(EdsTest, MalformedFilesAreRefusedWithFileLineAndWhat) {
  EXPECT_EQ(error_of("[DeviceInfo]\nVendorNumber=1\nthis is not ini\n"),
            "drive.eds:3: not an INI line (expected [Section], Key=Value or a ; comment)");
  EXPECT_EQ(error_of("[FileInfo]\nFileName=x\n"), "drive.eds:1: no [DeviceInfo] section");
  std::string text = kHeader;
  text.replace(text.find("ProductNumber=1234"), 18, "ProductNumber=12x4");
  EXPECT_EQ(error_of(text),
            "drive.eds:3: [DeviceInfo] ProductNumber=12x4: not a number (decimal, 0x "
            "hexadecimal or 0 octal)");
  text = kHeader;
  text.replace(text.find("3=0x1018"), 8, "3=0x1017");
  EXPECT_EQ(error_of(text), "drive.eds:12: object 0x1017 is listed but has no [1017] section");
  text = kHeader;
  text.replace(text.find("DataType=0x0005\nAccessType=ro\nPDOMapping"), 15, "DataType=0x10000");
  EXPECT_EQ(error_of(text), "drive.eds:23: [1001] DataType=0x10000: not a type");
  text = kHeader;
  text.replace(text.find("AccessType=ro\nPDOMapping"), 13, "AccessType=rx");
  EXPECT_EQ(error_of(text),
            "drive.eds:24: [1001] AccessType=rx: not one of ro, wo, rw, rwr, rww, const");
  text = kHeader;
  text.replace(text.find("PDOMapping=1"), 12, "PDOMapping=2");
  EXPECT_EQ(error_of(text), "drive.eds:25: [1001] PDOMapping must be 0 or 1");
  text = kHeader;
  text.replace(text.find("SubNumber=2"), 11, "SubNumber=3");
  EXPECT_EQ(error_of(text), "drive.eds:30: [1018] SubNumber=3 but 2 [1018subN] sections");
  text = kHeader;
  text.replace(text.find("DefaultValue=1\n"), 14, "DefaultValue=256");
  EXPECT_EQ(error_of(text), "drive.eds:36: [1018sub0] DefaultValue=256 does not fit UNSIGNED8");
  text = kHeader;
  text.replace(text.find("ParameterName=Error register\n"), 29, "");
  EXPECT_EQ(error_of(text), "drive.eds:21: [1001] has no ParameterName");
  text = kHeader + "[1000]\nDataType=0x0006\n";
  EXPECT_EQ(error_of(text), "drive.eds:44: [1000] DataType is given twice (line 16 and here)");
  text = kHeader;
  text.replace(text.find("SupportedObjects=3"), 18, "SupportedObjects=4");
  EXPECT_EQ(error_of(text),
            "drive.eds:9: [MandatoryObjects] SupportedObjects=4 but there is no entry 4");
  text = kHeader;
  const std::string list = "SupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018";
  text.replace(text.find(list), list.size(), "SupportedObjects=2\n1=0x1000\n2=0x1018");
  EXPECT_EQ(error_of(text),
            "drive.eds:1: no object 0x1001 (error register), which CiA 301 makes mandatory");
  EXPECT_EQ(error_of(kHeader + "[X]\nK=" + std::string(300, 'v') + "\n"),
            "drive.eds:44: the line is longer than 198 characters");
  EXPECT_EQ(error_of(kHeader), "");
}

// Objects of a vendor's own data types: a DEFTYPE of a basic type, a
// DEFSTRUCT, and a code nothing defines.
const char* const kVendorTypedObjects = R"(
[0040]
ParameterName=Vendor's 32-bit type
ObjectType=0x5
DataType=0x0007

[0041]
ParameterName=Vendor's structure
ObjectType=0x6
SubNumber=1

[0041sub0]
ParameterName=Number of members
DataType=0x0005
AccessType=const
DefaultValue=2

[ManufacturerObjects]
SupportedObjects=3
1=0x2000
2=0x2001
3=0x2002

[2000]
ParameterName=Counter
DataType=0x0040
AccessType=ro
DefaultValue=0x12345678

[2001]
ParameterName=Tuning set
DataType=0x0041
AccessType=rw

[2002]
ParameterName=Diagnostics
DataType=0x0047
AccessType=ro
DefaultValue=not a number
)";

// What vendors ship: their own data types (a DEFTYPE of a basic type is
// that type; a DEFSTRUCT or a code nothing defines is kept as opaque, with
// a note, never refused) in objects a controller may not use.
TEST(EdsTest, ManufacturerTypesAreResolvedOrKeptOpaqueWithANote) {
  const Eds eds = parse_eds(kHeader + kVendorTypedObjects, "drive.eds");
  const EdsVariable* counter = eds.find(0x2000, 0);
  ASSERT_NE(counter, nullptr);
  EXPECT_EQ(counter->data_type, data_type::kUnsigned32);
  EXPECT_EQ(counter->declared_type, 0x0040);
  EXPECT_EQ(counter->size_bytes(), 4u);
  EXPECT_EQ(counter->default_value(1), 0x12345678u);
  ASSERT_NE(eds.find(0x2001, 0), nullptr);
  EXPECT_TRUE(eds.find(0x2001, 0)->opaque);
  EXPECT_EQ(eds.find(0x2001, 0)->size_bytes(), 0u);
  EXPECT_TRUE(eds.find(0x2002, 0)->opaque);
  EXPECT_FALSE(eds.find(0x2002, 0)->default_value(1));
  ASSERT_EQ(eds.notes.size(), 2u);
  EXPECT_EQ(eds.notes[0],
            "drive.eds:74: [2001] DataType=0x0041 is a DEFSTRUCT of this file: kept as opaque "
            "(its size is not known)");
  EXPECT_EQ(eds.notes[1],
            "drive.eds:79: [2002] DataType=0x0047 is not a basic type nor a DEFTYPE of one in "
            "this file: kept as opaque (its size is not known)");
}

// A malformed manufacturer object (0x2000-0x5FFF, which the bring-up never
// uses; a vendor's [20A0] with SubNumber=8 but one sub-section) is left out
// with a note naming its line, so that the drive's real problems show; the
// same in a standard object is still refused.
TEST(EdsTest, AMalformedManufacturerObjectIsLeftOutWithANote) {
  std::string text = kHeader + kVendorTypedObjects;
  text.replace(text.find("SupportedObjects=3\n1=0x2000"), 27,
               "SupportedObjects=4\n4=0x20A0\n1=0x2000");
  text +=
      "\n[20A0]\nParameterName=Vendor record\nObjectType=0x9\nSubNumber=8\n\n"
      "[20A0sub0]\nParameterName=Count\nDataType=0x0005\nAccessType=const\n"
      "DefaultValue=7\n";
  const Eds eds = parse_eds(text, "drive.eds");
  EXPECT_EQ(eds.find(0x20A0, 0), nullptr);
  ASSERT_NE(eds.find(0x2000, 0), nullptr);
  ASSERT_EQ(eds.notes.size(), 3u);
  EXPECT_NE(eds.notes[0].find("[20a0] SubNumber=8 but 1 [20a0subN] sections: a manufacturer "
                              "object (0x2000-0x5FFF), which the bring-up does not use: left out"),
            std::string::npos)
      << eds.notes[0];
  EXPECT_EQ(eds.notes[0].rfind("drive.eds:", 0), 0u) << eds.notes[0];
}

// Latin-1 text (a vendor's umlaut in a name) is read as such, and said.
TEST(EdsTest, Latin1TextIsReadAsLatin1) {
  std::string text = kHeader;
  text.replace(text.find("Example drive"), 13, "Antrieb f\xFCr Achsen");
  const Eds eds = parse_eds(text, "drive.eds");
  EXPECT_EQ(eds.identity.product_name, "Antrieb f\xC3\xBCr Achsen");
  ASSERT_EQ(eds.notes.size(), 1u);
  EXPECT_EQ(eds.notes[0], "drive.eds:1: not UTF-8: read as Latin-1 (ISO 8859-1)");
  std::string utf8 = kHeader;
  utf8.replace(utf8.find("Example drive"), 13, "Antrieb f\xC3\xBCr Achsen");
  const Eds as_utf8 = parse_eds(utf8, "drive.eds");
  EXPECT_EQ(as_utf8.identity.product_name, "Antrieb f\xC3\xBCr Achsen");
  EXPECT_TRUE(as_utf8.notes.empty());
}

// A DCF: the device's configured values (ParameterValue) over the
// defaults, and the node ID it was configured for.
TEST(EdsTest, ADcfsParameterValuesAreTheDevicesValues) {
  const Eds dcf = parse_eds(kHeader + R"(
[DeviceComissioning]
NodeID=5
Baudrate=1000

[OptionalObjects]
SupportedObjects=1
1=0x1017

[1017]
ParameterName=Producer heartbeat time
DataType=0x0006
AccessType=rw
DefaultValue=0
ParameterValue=100
)",
                            "drive.dcf");
  EXPECT_TRUE(dcf.dcf);
  EXPECT_EQ(dcf.node_id, 5);
  EXPECT_EQ(dcf.find(0x1017, 0)->default_value(5), 0u);
  EXPECT_EQ(dcf.find(0x1017, 0)->value(5), 100u);
  EXPECT_EQ(dcf.find(0x1000, 0)->value(5), 0x00020192u);  // no ParameterValue: the default
  std::string bad = kHeader + "\n[DeviceComissioning]\nNodeID=200\n";
  EXPECT_EQ(error_of(bad), "drive.eds:45: [DeviceComissioning] NodeID must be 1 to 127");
}

// CiA 306's compact storage: an ARRAY's sub-indices from one section,
// their names and values from [XXXXName] and [XXXXValue].
TEST(EdsTest, ACompactArrayHasItsSubIndices) {
  const Eds eds = parse_eds(kHeader + R"(
[OptionalObjects]
SupportedObjects=1
1=0x1016

[1016]
ParameterName=Consumer heartbeat time
ObjectType=0x8
DataType=0x0007
AccessType=rw
DefaultValue=0
PDOMapping=0
CompactSubObj=3

[1016Name]
NrOfEntries=1
2=Second consumer

[1016Value]
NrOfEntries=1
3=0x00100096
)",
                            "drive.eds");
  ASSERT_NE(eds.find(0x1016, 0), nullptr);
  EXPECT_EQ(eds.find(0x1016, 0)->value(1), 3u);
  EXPECT_FALSE(writable(eds.find(0x1016, 0)->access));
  ASSERT_NE(eds.find(0x1016, 3), nullptr);
  EXPECT_EQ(eds.find(0x1016, 4), nullptr);
  EXPECT_TRUE(writable(eds.find(0x1016, 1)->access));
  EXPECT_EQ(eds.find(0x1016, 1)->size_bytes(), 4u);
  EXPECT_EQ(eds.find(0x1016, 1)->value(1), 0u);
  EXPECT_EQ(eds.find(0x1016, 3)->value(1), 0x00100096u);
  EXPECT_EQ(eds.find(0x1016, 1)->name, "Consumer heartbeat time 1");
  EXPECT_EQ(eds.find(0x1016, 2)->name, "Second consumer");
  EXPECT_EQ(error_of(kHeader + "\n[OptionalObjects]\nSupportedObjects=1\n1=0x1016\n\n[1016]\n"
                               "ParameterName=C\nObjectType=0x8\nDataType=0x0007\n"
                               "AccessType=rw\nCompactSubObj=0\n"),
            "drive.eds:53: [1016] CompactSubObj must be 1 to 254");
}

// A RECORD's sub-indices are its sections [XXXXsubN], N in hex as CiA 306
// writes it (any case, no leading zero) up to 0xFE; a problem names the
// lowest sub-index that has one.
TEST(EdsTest, AnObjectsSubIndicesAreItsSubNSections) {
  const std::string record = kHeader + R"(
[OptionalObjects]
SupportedObjects=1
1=0x6010

[6010]
ParameterName=Record
ObjectType=0x9
SubNumber=4
)";
  const auto sub = [](const std::string& n, const std::string& type) {
    return "\n[6010sub" + n + "]\nParameterName=Entry " + n + "\nDataType=" + type +
           "\nAccessType=rw\n";
  };
  // Sections that name no sub-index: a leading zero, beyond 0xFE, not hex.
  const std::string others = sub("01", "0x0005") + sub("FF", "0x0005") + sub("1x", "0x0005") +
                             sub("", "0x0005") + "\n[6011sub1]\nK=1\n";
  const Eds eds = parse_eds(record + sub("10", "0x0007") + sub("0", "0x0005") + sub("A", "0x0006") +
                                sub("2", "0x0005") + others,
                            "drive.eds");
  std::vector<unsigned> subs;
  for (const auto& [key, v] : eds.variables) {
    if (key.first == 0x6010) subs.push_back(key.second);
  }
  EXPECT_EQ(subs, (std::vector<unsigned>{0, 2, 0xA, 0x10}));
  EXPECT_EQ(eds.find(0x6010, 0xA)->name, "Entry A");
  EXPECT_EQ(eds.find(0x6010, 0x10)->size_bytes(), 4u);
  EXPECT_EQ(error_of(record + sub("10", "0x10000") + sub("0", "0x0005") + sub("A", "0x10000") +
                     sub("2", "0x0005") + others),
            "drive.eds:65: [6010suba] DataType=0x10000: not a type");
  EXPECT_EQ(error_of(record + sub("0", "0x0005") + sub("2", "0x0005") + others),
            "drive.eds:51: [6010] SubNumber=4 but 2 [6010subN] sections");
}

// Identity numbers a file leaves out are unknown, not an error.
TEST(EdsTest, IdentityNumbersAreOptional) {
  std::string text = kHeader;
  text.replace(text.find("ProductNumber=1234\n"), 19, "");
  text.replace(text.find("RevisionNumber=0x00020003\n"), 26, "");
  const Eds eds = parse_eds(text, "drive.eds");
  EXPECT_EQ(eds.identity.vendor_id, 0xABu);
  EXPECT_FALSE(eds.identity.product_code);
  EXPECT_FALSE(eds.identity.revision);
}

TEST(EdsTest, AMissingFileIsNamed) {
  try {
    read_eds("/nonexistent/drive.eds");
    FAIL() << "no error";
  } catch (const EdsError& e) {
    EXPECT_EQ(std::string(e.what()),
              "/nonexistent/drive.eds: cannot open: No such file or directory");
  }
}

TEST(EdsTest, TheProductsOwnEdsFilesAreValid) {
  const Eds drive = read_eds(DELTA_EDS_DIR "/delta_drive_emu.eds");
  EXPECT_EQ(drive.identity.vendor_id, 0x0000DE17u);
  EXPECT_EQ(drive.identity.product_code, 0x00000402u);
  EXPECT_EQ(drive.find(0x1018, 4)->default_value(2), 0x00010002u);
  EXPECT_EQ(drive.find(0x1801, 1)->default_value(2), 0x80000282u);
}

// A complete EDS by CiA 306: every [DeviceInfo] key, every object listed in
// its list, TPDO1 with its mapping (the error register and a dummy byte).
// A finding's line is that of its section's first key.
const char* const kCompleteDeviceInfo = R"([DeviceInfo]
VendorName=Example
VendorNumber=0x000000AB
ProductName=Example drive
ProductNumber=1234
RevisionNumber=0x00020003
OrderCode=EX-1
BaudRate_10=0
BaudRate_20=0
BaudRate_50=0
BaudRate_125=1
BaudRate_250=1
BaudRate_500=1
BaudRate_800=0
BaudRate_1000=1
SimpleBootUpMaster=0
SimpleBootUpSlave=1
Granularity=8
DynamicChannelsSupported=0
GroupMessaging=0
NrOfRXPDO=0
LSS_Supported=0
)";

const char* const kCompleteObjects = R"(
[DummyUsage]
Dummy0005=1

[MandatoryObjects]
SupportedObjects=3
1=0x1000
2=0x1001
3=0x1018

[1000]
ParameterName=Device type
DataType=0x0007
AccessType=ro
DefaultValue=0x00020192

[1001]
ParameterName=Error register
DataType=0x0005
AccessType=ro
PDOMapping=1

[1018]
ParameterName=Identity
ObjectType=0x9
SubNumber=2

[1018sub0]
ParameterName=Highest sub-index
DataType=0x0005
AccessType=const
DefaultValue=1

[1018sub1]
ParameterName=Vendor-ID
DataType=0x0007
AccessType=ro
DefaultValue=0x000000AB

[OptionalObjects]
SupportedObjects=2
1=0x1800
2=0x1A00

[1800]
ParameterName=TPDO1 communication
ObjectType=0x9
SubNumber=3

[1800sub0]
ParameterName=Highest sub-index
DataType=0x0005
AccessType=const
DefaultValue=2

[1800sub1]
ParameterName=COB-ID
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x180

[1800sub2]
ParameterName=Transmission type
DataType=0x0005
AccessType=rw
DefaultValue=1

[1A00]
ParameterName=TPDO1 mapping
ObjectType=0x9
SubNumber=3

[1A00sub0]
ParameterName=Number of entries
DataType=0x0005
AccessType=rw
DefaultValue=2

[1A00sub1]
ParameterName=Entry 1
DataType=0x0007
AccessType=rw
DefaultValue=0x10010008

[1A00sub2]
ParameterName=Entry 2
DataType=0x0007
AccessType=rw
DefaultValue=0x00050008
)";

std::string complete_eds(const std::string& device_info_extra = "NrOfTXPDO=1\n") {
  return kCompleteDeviceInfo + device_info_extra + kCompleteObjects;
}

// The findings of the completeness check on `text`.
std::vector<std::string> findings_of(const std::string& text) {
  return check_eds_complete(parse_eds(text, "drive.eds"));
}

// Whether one of `findings` is `expected` exactly.
::testing::AssertionResult has_finding(const std::vector<std::string>& findings,
                                       const std::string& expected) {
  if (std::find(findings.begin(), findings.end(), expected) != findings.end()) {
    return ::testing::AssertionSuccess();
  }
  auto failure = ::testing::AssertionFailure() << "no finding '" << expected << "'; found:";
  for (const std::string& f : findings) failure << "\n  " << f;
  return failure;
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

TEST(EdsCompletenessTest, ACompleteEdsHasNoFinding) {
  EXPECT_TRUE(findings_of(complete_eds()).empty());
}

TEST(EdsCompletenessTest, APdoCommunicationObjectWithoutItsMappingIsFound) {
  std::string text = complete_eds();
  text = replaced(text, "SupportedObjects=2\n1=0x1800\n2=0x1A00", "SupportedObjects=1\n1=0x1800");
  text = text.substr(0, text.find("[1A00]"));
  EXPECT_TRUE(has_finding(findings_of(text),
                          "drive.eds:68: PDO communication object 0x1800 has no mapping object "
                          "0x1A00"));
}

TEST(EdsCompletenessTest, MappingEntriesMustNameMappableObjectsOfTheirLength) {
  EXPECT_TRUE(has_finding(findings_of(replaced(complete_eds(), "0x10010008", "0x10000020")),
                          "drive.eds:103: 0x1A00:01 maps 0x1000:00, which is not PDOMapping=1"));
  EXPECT_TRUE(has_finding(findings_of(replaced(complete_eds(), "0x10010008", "0x10010010")),
                          "drive.eds:103: 0x1A00:01 maps 0x1001:00 with 16 bits; it has 8"));
  EXPECT_TRUE(has_finding(findings_of(replaced(complete_eds(), "0x10010008", "0x60710010")),
                          "drive.eds:103: 0x1A00:01 maps 0x6071:00, which the EDS does not have"));
  EXPECT_TRUE(has_finding(findings_of(replaced(complete_eds(), "Dummy0005=1", "Dummy0005=0")),
                          "drive.eds:109: 0x1A00:02 maps dummy 0x0005, which [DummyUsage] does "
                          "not enable"));
}

TEST(EdsCompletenessTest, ObjectListsMatchTheSections) {
  const std::string unlisted = replaced(complete_eds(), "SupportedObjects=2\n1=0x1800\n2=0x1A00",
                                        "SupportedObjects=1\n1=0x1800");
  EXPECT_TRUE(has_finding(findings_of(unlisted),
                          "drive.eds:91: object 0x1A00 has a section but no object list names it "
                          "(add it to [OptionalObjects])"));
  const std::string misplaced =
      replaced(complete_eds(), "SupportedObjects=2\n1=0x1800\n2=0x1A00",
               "SupportedObjects=3\n1=0x1800\n2=0x1A00\n3=0x2000") +
      "\n[2000]\nParameterName=Vendor's\nDataType=0x0005\nAccessType=ro\n";
  EXPECT_TRUE(has_finding(findings_of(misplaced),
                          "drive.eds:67: [OptionalObjects] names 0x2000, which belongs in "
                          "[ManufacturerObjects]"));
}

TEST(EdsCompletenessTest, DeviceInfoHasEveryKeyAndCountsThePdos) {
  EXPECT_TRUE(has_finding(findings_of(replaced(complete_eds(), "Granularity=8\n", "")),
                          "drive.eds:2: [DeviceInfo] has no Granularity"));
  EXPECT_TRUE(has_finding(findings_of(complete_eds("NrOfTXPDO=2\n")),
                          "drive.eds:23: [DeviceInfo] NrOfTXPDO=2 but the EDS has 1 TPDO "
                          "communication objects (0x1800..)"));
  EXPECT_TRUE(
      has_finding(findings_of(replaced(complete_eds(), "BaudRate_1000=1", "BaudRate_1000=2")),
                  "drive.eds:15: [DeviceInfo] BaudRate_1000=2: must be 0 or 1"));
  EXPECT_TRUE(has_finding(findings_of(replaced(complete_eds(), "DefaultValue=2\n\n[1800sub1]",
                                               "DefaultValue=4\n\n[1800sub1]")),
                          "drive.eds:74: 0x1800:00 says 4 sub-indices, but the highest is 2"));
}

// Every EDS the project ships is complete, so that the CANopen tools users
// have can build a node from it.
TEST(EdsCompletenessTest, EveryShippedEdsIsComplete) {
  std::vector<std::string> paths;
  for (const auto& entry : std::filesystem::directory_iterator(DELTA_EDS_DIR)) {
    if (entry.path().extension() == ".eds") paths.push_back(entry.path().string());
  }
  EXPECT_GE(paths.size(), 3u);
  for (const std::string& path : paths) {
    const std::vector<std::string> findings = check_eds_complete(read_eds(path));
    EXPECT_TRUE(findings.empty()) << path << ": " << findings.size() << " findings, first "
                                  << (findings.empty() ? "" : findings.front());
  }
}

}  // namespace
}  // namespace delta::canopen
