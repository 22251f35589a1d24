// Prints the golden vectors on the host (see golden_vectors.hpp).
#include <cstdio>

#include "golden_vectors.hpp"

namespace {
class StdoutSink final : public fw::golden::TextSink {
 public:
  void write(const char* text) override { std::fputs(text, stdout); }
};
}  // namespace

int main() {
  StdoutSink sink;
  fw::golden::write_golden_vectors(sink);
  return std::fflush(stdout) == 0 ? 0 : 1;
}
