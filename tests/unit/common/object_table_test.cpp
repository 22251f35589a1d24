// The object table behind a node's SDO server (delta/canopen/object_table.hpp):
// objects found by index and sub-index, what is not there named as a missing
// object or a missing sub-index, writes only where there is a setter, and
// scalars out of index order (or twice) refused.
#include "delta/canopen/object_table.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace delta::canopen {
namespace {

namespace sdo = can::sdo;

struct Node {
  std::uint32_t word{0x11223344};
};
using Table = ObjectTable<Node*>;

const Table::Scalar kScalars[] = {
    {0x1000, 0, 4, [](Node* const& n) { return n->word; }, nullptr},
    {0x1018, 0, 1, [](Node* const&) { return 2u; }, nullptr},
    {0x1018, 2, 4, [](Node* const& n) { return n->word; },
     [](Node*& n, std::uint32_t v) {
       n->word = v;
       return sdo::kNoAbort;
     }},
    {0x2000, 1, 2, [](Node* const&) { return 7u; }, nullptr},
};
const Table::Text kTexts[] = {{0x1008, 0, [](Node* const&) { return std::string("name"); }}};

sdo::AbortCode find(Table& t, std::uint16_t index, std::uint8_t sub) {
  sdo::ObjectInfo info;
  return t.find(index, sub, info);
}

TEST(ObjectTableTest, FindsObjectsAndNamesWhatIsMissing) {
  Node node;
  Table t(&node, kScalars, kTexts);
  EXPECT_EQ(find(t, 0x1000, 0), sdo::kNoAbort);
  EXPECT_EQ(find(t, 0x1018, 2), sdo::kNoAbort);
  EXPECT_EQ(find(t, 0x2000, 1), sdo::kNoAbort);
  EXPECT_EQ(find(t, 0x1008, 0), sdo::kNoAbort);
  // A sub-index the object does not have: between, after or before its own.
  EXPECT_EQ(find(t, 0x1018, 1), sdo::kAbortSubindexDoesNotExist);
  EXPECT_EQ(find(t, 0x1018, 3), sdo::kAbortSubindexDoesNotExist);
  EXPECT_EQ(find(t, 0x2000, 0), sdo::kAbortSubindexDoesNotExist);
  EXPECT_EQ(find(t, 0x1008, 1), sdo::kAbortSubindexDoesNotExist);
  // An object it does not have: between, before and after its own.
  EXPECT_EQ(find(t, 0x1001, 0), sdo::kAbortObjectDoesNotExist);
  EXPECT_EQ(find(t, 0x0FFF, 0), sdo::kAbortObjectDoesNotExist);
  EXPECT_EQ(find(t, 0x3000, 0), sdo::kAbortObjectDoesNotExist);

  std::array<std::uint8_t, 4> bytes{};
  EXPECT_EQ(t.read(0x1000, 0, 0, bytes), sdo::kNoAbort);
  EXPECT_EQ(bytes, (std::array<std::uint8_t, 4>{0x44, 0x33, 0x22, 0x11}));
  EXPECT_EQ(t.read(0x1018, 1, 0, bytes), sdo::kAbortSubindexDoesNotExist);
  const std::array<std::uint8_t, 4> value{1, 2, 3, 4};
  EXPECT_EQ(t.write(0x1018, 2, 0, value, true), sdo::kNoAbort);
  EXPECT_EQ(node.word, 0x04030201u);
  EXPECT_EQ(t.write(0x1000, 0, 0, value, true), sdo::kAbortReadOnly);
  EXPECT_EQ(t.write(0x1008, 0, 0, value, true), sdo::kAbortReadOnly);
  EXPECT_EQ(t.write(0x1001, 0, 0, value, true), sdo::kAbortObjectDoesNotExist);
}

TEST(ObjectTableTest, ScalarsOutOfIndexOrderOrTwiceAreRefused) {
  Node node;
  const Table::Scalar unordered[] = {kScalars[2], kScalars[1]};
  EXPECT_THROW(Table(&node, unordered, kTexts), std::invalid_argument);
  const Table::Scalar twice[] = {kScalars[1], kScalars[1]};
  EXPECT_THROW(Table(&node, twice, kTexts), std::invalid_argument);
}

}  // namespace
}  // namespace delta::canopen
