// The register map (delta/modbus/register_map.hpp) against docs/modbus.md,
// and its registers' layout.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "delta/modbus/register_map.hpp"

namespace fw_linux {
namespace {

namespace mb = delta::modbus;

TEST(RegisterMapTest, DocsModbusMdListsEveryRegisterAsTheMapDefinesIt) {
  std::ifstream in("docs/modbus.md");
  ASSERT_TRUE(in.good()) << "run from the source directory";
  const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::size_t rows = 0;
  for (const mb::Register& r : mb::kRegisters) {
    const bool input = r.table == mb::Table::kInput;
    const char* types[] = {"u16", "i16", "u32", "i32"};
    std::string scale = r.scale_num == 1 && r.scale_den == 1
                            ? (std::string(r.unit).empty() ? "–" : r.unit)
                            : std::string(r.unit) + " × " + std::to_string(r.scale_num) + "/" +
                                  std::to_string(r.scale_den);
    const std::string row = "| " + std::to_string((input ? 30001 : 40001) + r.address) + " | " +
                            std::to_string(r.address) + " | `" + r.name + "` | " +
                            types[static_cast<int>(r.type)] + " | " + scale + " | " +
                            r.description + " |";
    EXPECT_NE(doc.find(row), std::string::npos) << "docs/modbus.md lacks or differs on:\n" << row;
    ++rows;
  }
  EXPECT_EQ(rows, mb::kRegisters.size());
}

TEST(RegisterMapTest, RegistersDoNotOverlapAndFitTheirTables) {
  for (std::size_t i = 0; i < mb::kRegisters.size(); ++i) {
    const mb::Register& a = mb::kRegisters[i];
    EXPECT_NE(std::string(a.name), "");
    for (std::size_t k = 0; k < i; ++k) {
      const mb::Register& b = mb::kRegisters[k];
      EXPECT_NE(std::string(a.name), b.name);
      if (a.table != b.table) continue;
      const bool apart =
          a.address + mb::width(a.type) <= b.address || b.address + mb::width(b.type) <= a.address;
      EXPECT_TRUE(apart) << a.name << " overlaps " << b.name;
    }
  }
  std::vector<std::uint16_t> regs(mb::kInputCount);
  mb::encode(mb::named("q1"), -123456, regs.data());
  EXPECT_EQ(mb::decode(mb::named("q1"), regs.data()), -123456);
  mb::encode(mb::named("cycle_counter"), 0x12345678, regs.data());
  EXPECT_EQ(regs[6], 0x1234) << "high word first";
  EXPECT_EQ(regs[7], 0x5678);
}

}  // namespace
}  // namespace fw_linux
