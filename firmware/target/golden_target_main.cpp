// The Cortex-M test image: prints the golden vectors through semihosting.
#include "golden_vectors.hpp"
#include "semihosting.hpp"

extern "C" int firmware_main();

namespace {
class SemihostingSink final : public fw::golden::TextSink {
 public:
  void write(const char* text) override { semihosting::write(text); }
};
}  // namespace

extern "C" int firmware_main() {
  SemihostingSink sink;
  return fw::golden::write_golden_vectors(sink) > 0 ? 0 : 1;
}
