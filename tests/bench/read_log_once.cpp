// Reads and parses one delta-log/1 file once, in a fresh process, as the
// first thing `host_id fit` does: the reference time of the fit's speed bar
// (tests/bench/fit_speed.py). Prints the sample count.
#include <cstdio>
#include <exception>

#include "host_id/delta_log.hpp"
#include "host_id/memory.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: read_log_once LOG.csv\n");
    return 2;
  }
  host_id::keep_freed_memory_for_reuse();  // as host_id's main does
  try {
    const host_id::DeltaLog log = host_id::read_delta_log(argv[1]);
    std::printf("%zu samples\n", log.size());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "read_log_once: %s\n", e.what());
    return 1;
  }
}
