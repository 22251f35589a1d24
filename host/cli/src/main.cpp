#include <iostream>
#include <string>
#include <vector>

#include "host_id/cli.hpp"
#include "host_id/memory.hpp"

int main(int argc, char** argv) {
  host_id::keep_freed_memory_for_reuse();
  return host_id::run_cli(std::vector<std::string>(argv + 1, argv + argc), std::cout, std::cerr);
}
