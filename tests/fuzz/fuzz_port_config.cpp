// libFuzzer harness: delta_fw's configuration reader. Any file is either
// refused with ConfigError or gives a configuration whose every value the
// controller can take (controller_config() does not throw: validate() has
// checked it) and whose tick counts are not 0.

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "fw_linux/config.hpp"
#include "scratch_directory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path =
      testsupport::process_scratch("fuzz_port_config").file("port.conf");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  fw_linux::PortConfig c;
  try {
    c = fw_linux::read_port_config(path);
  } catch (const fw_linux::ConfigError&) {
    return 0;
  }
  try {
    const fw::ControllerConfig core = fw_linux::controller_config(c);
    if (core.stop_ticks == 0 || core.approach_ticks == 0) std::abort();
  } catch (const fw_linux::ConfigError&) {
    std::abort();  // accepted, yet not representable
  }
  return 0;
}
