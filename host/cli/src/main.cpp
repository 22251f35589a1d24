#include <iostream>
#include <string>
#include <vector>

#include "delta/atomic_file.hpp"
#include "host_id/cli.hpp"
#include "host_id/memory.hpp"

int main(int argc, char** argv) {
  host_id::keep_freed_memory_for_reuse();
  delta::remove_temporaries_on_signals();  // Ctrl-C leaves no half-written output
  return host_id::run_cli(std::vector<std::string>(argv + 1, argv + argc), std::cout, std::cerr);
}
