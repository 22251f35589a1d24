#include <iostream>
#include <string>
#include <vector>

#include "host_id/cli.hpp"

int main(int argc, char** argv) {
  return host_id::run_cli(std::vector<std::string>(argv + 1, argv + argc), std::cout, std::cerr);
}
