// libFuzzer harness: the EDS reader. Any text is either refused with
// EdsError naming a line inside the text, or read into a dictionary whose
// every variable has a known data type (or is opaque: a type the file does
// not define as a basic one) and whose mandatory objects exist; every note
// and every finding of the completeness check names the file.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "delta/canopen/eds.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  delta::canopen::Eds eds;
  try {
    eds = delta::canopen::parse_eds(text, "f.eds");
  } catch (const delta::canopen::EdsError& e) {
    const std::string what = e.what();
    if (what.rfind("f.eds:", 0) != 0) std::abort();  // every message names the file
    return 0;
  }
  for (const auto& [key, v] : eds.variables) {
    if (!v.opaque && !delta::canopen::data_type_size(v.data_type)) std::abort();
    if (v.opaque && v.size_bytes() != 0) std::abort();
    if (key.first != v.index || key.second != v.subindex) std::abort();
    (void)v.default_value(127);
    (void)v.value(127);
  }
  if (!eds.has_object(0x1000) || !eds.has_object(0x1001) || !eds.has_object(0x1018)) std::abort();
  for (const std::string& note : eds.notes) {
    if (note.rfind("f.eds:", 0) != 0) std::abort();
  }
  for (const std::string& finding : delta::canopen::check_eds_complete(eds)) {
    if (finding.rfind("f.eds:", 0) != 0) std::abort();
  }
  return 0;
}
