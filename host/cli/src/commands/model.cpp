// host_id model load|show: the identified model the controller runs as its
// feed-forward, over CAN by SDO (docs/protocol.md, 0x2200).
#include <memory>
#include <ostream>
#include <string>

#include "commands/command.hpp"
#include "delta/identified_model.hpp"
#include "host_id/model_transfer.hpp"

namespace host_id {

namespace {

struct ModelCommandOptions {
  std::string result;
  ModelLink link;
};

void add_link_options(CLI::App* c, ModelLink& link) {
  c->add_option("--can", link.iface, "the CAN interface")->required();
  c->add_option("--node", link.node, "the controller's node")
      ->check(CLI::Range(1, 127))
      ->capture_default_str();
  c->add_option("--timeout-ms", link.timeout_ms, "how long to wait for each answer")
      ->check(CLI::Range(1, 60000))
      ->capture_default_str();
}

void run_load(const ModelCommandOptions& o, CommandContext& context) {
  const delta::IdentifiedModel m = delta::read_identified_model(o.result);
  try {
    load_model(o.link, m);
  } catch (const ModelTransferError& e) {
    context.err << "host_id model: error: " << e.message << "\n";
    context.exit_code = e.exit_code;
    return;
  }
  context.err << "host_id model: loaded " << o.result << " (" << m.kind << ", fit "
              << hex32(m.fit_id) << ") into node " << o.link.node
              << "; it is the feed-forward from the next run on, and kept across restarts\n";
  if (const std::string left_out = delta::left_out_by_controller(m); !left_out.empty()) {
    context.err << "host_id model: note: " << left_out << "\n";
  }
  context.exit_code = 0;
}

void run_show(const ModelCommandOptions& o, CommandContext& context) {
  try {
    print_model(read_model(o.link), context.out);
    context.exit_code = 0;
  } catch (const ModelTransferError& e) {
    context.err << "host_id model: error: " << e.message << "\n";
    context.exit_code = e.exit_code;
  }
}

}  // namespace

void add_model_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "The identified model the controller runs as its feed-forward (docs/using-the-model.md, "
      "\"Using the model\"). load writes a saved fit (host_id fit LOG --out RESULT.json) to "
      "the controller by SDO; it checks the model whole (kind, geometry, every value), uses it "
      "from the next run on and keeps it across restarts. show prints the model in use. Exit "
      "status 2: the model cannot run (its values or geometry); 3: the controller refused it "
      "(the reason is printed); 4: no answer.");
  c->require_subcommand(1);
  auto load = std::make_shared<ModelCommandOptions>();
  CLI::App* l = c->add_subcommand("load", "load a saved fit into the controller");
  l->add_option("RESULT", load->result, "a result saved by host_id fit --out")
      ->required()
      ->check(CLI::ExistingFile);
  add_link_options(l, load->link);
  l->callback([load, &context] { run_load(*load, context); });
  auto show = std::make_shared<ModelCommandOptions>();
  CLI::App* s = c->add_subcommand("show", "print the feed-forward and model in use");
  add_link_options(s, show->link);
  s->callback([show, &context] { run_show(*show, context); });
}

}  // namespace host_id
