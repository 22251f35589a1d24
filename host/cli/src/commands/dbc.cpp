// host_id dbc [-o FILE.dbc]: the bus's DBC description.
#include "host_id/dbc.hpp"

#include <memory>
#include <ostream>

#include "commands/command.hpp"
#include "delta/atomic_file.hpp"

namespace host_id {

void add_dbc_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Writes the DBC description of the controller's CAN bus (the protocol table, "
      "docs/protocol.md) to FILE or stdout.");
  auto path = std::make_shared<std::string>();
  c->add_option("-o,--out", *path, "the DBC file to write (atomically)")->check(kOutputPath);
  c->callback([path, &context] {
    if (path->empty()) {
      context.out << make_dbc();
    } else {
      delta::write_file_atomically(*path, make_dbc());
    }
    context.exit_code = 0;
  });
}

}  // namespace host_id
