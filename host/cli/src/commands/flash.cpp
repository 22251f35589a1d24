// host_id flash: its options, and the closing line of a flash
// (host_id/flash.hpp does the work).
#include "host_id/flash.hpp"

#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

#include "commands/command.hpp"
#include "delta/update/image_file.hpp"

namespace host_id {

namespace {

// The flash's outcome: as JSON (--json) or one line.
void print_flashed(const FlashOptions& o, const FlashReport& r, bool json, std::ostream& out) {
  if (r.key_replaced) {
    char keys[64];
    std::snprintf(keys, sizeof keys, "%08X... by %08X...", r.key_replaced->first,
                  r.key_replaced->second);
    if (json) {
      out << nlohmann::json{{"image", o.image}, {"node", o.node}, {"key_replaced", keys}}.dump(2)
          << "\n";
    } else {
      out << "flashed " << o.image << ": node " << o.node << " replaced its public key (" << keys
          << "); images must be signed with the new key's secret from now on\n";
    }
    return;
  }
  if (json) {
    out << nlohmann::json{{"image", o.image},
                          {"node", o.node},
                          {"version", delta::update::version_text(r.flashed)},
                          {"was", delta::update::version_text(r.running_before)},
                          {"confirmed", true},
                          {"bytes", r.bytes},
                          {"seconds", r.seconds},
                          {"frames_sent", r.frames_sent}}
               .dump(2)
        << "\n";
    return;
  }
  char rate[64];
  std::snprintf(rate, sizeof rate, "%.2f s, %.1f kB/s", r.seconds,
                r.seconds > 0 ? static_cast<double>(r.bytes) / 1024.0 / r.seconds : 0.0);
  out << "flashed " << o.image << ": node " << o.node << " runs version "
      << delta::update::version_text(r.flashed) << " (was "
      << delta::update::version_text(r.running_before) << "), confirmed; " << r.bytes
      << " bytes in " << rate << ", " << r.frames_sent << " frames sent\n";
}

// The exit status: 0 flashed, else the failure's (the flash error's line
// on stderr).
int run_flash(const FlashOptions& o, bool json, CommandContext& context) {
  try {
    const FlashReport r = flash_image(o, context.err);
    print_flashed(o, r, json, context.out);
    return 0;
  } catch (const FlashError& e) {
    context.err << "host_id flash: error: " << e.message << "\n";
    return e.exit_code;
  }
}

}  // namespace

void add_flash_command(CLI::App& command, CommandContext& context) {
  auto o = std::make_shared<FlashOptions>();
  CLI::App* c = &command;
  c->description(
      "Sends a firmware image (host_id image make) to the controller by CiA 302-3 program "
      "download: checks the node's identity and version first, clears, block-downloads with "
      "progress, verifies the CRC-32 (0x1F56), starts the new program and waits until it "
      "confirms (docs/flashing.md). On any failure the old program keeps running. Exit status: "
      "0 flashed, 2 usage, 3 the controller refused (the flash status says why), 4 no answer or "
      "the transfer failed, 5 the image is invalid, for other hardware or older, 6 the CRC-32 "
      "does not match, 7 the new program rolled back or did not confirm.");
  c->add_option("IMAGE", o->image, "the image file")->required()->check(CLI::ExistingFile);
  c->add_option("--can", o->iface, "the CAN interface")->required();
  c->add_option("--node", o->node, "the controller's node")
      ->check(CLI::Range(1, 127))
      ->capture_default_str();
  c->add_flag("--allow-downgrade", o->allow_downgrade, "flash an older version");
  c->add_flag("--force", o->force,
              "send an image that fails the checks here (other hardware, a bad CRC) anyway; the "
              "controller checks it again and refuses it");
  c->add_option("--retries", o->retries, "start the transfer over this often after a bus error")
      ->check(CLI::Range(0, 10))
      ->capture_default_str();
  c->add_option("--confirm-timeout", o->confirm_timeout_s,
                "seconds to wait for the new program's confirmation")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
  c->add_option("--timeout-ms", o->timeout_ms, "how long to wait for each SDO answer")
      ->check(CLI::Range(10, 60000))
      ->capture_default_str();
  auto json = std::make_shared<bool>(false);
  c->add_flag("--quiet", o->quiet, "no progress and no step lines (warnings and errors stay)");
  c->add_flag("--json", *json, "the outcome as JSON on stdout");
  c->callback([o, json, &context] { context.exit_code = run_flash(*o, *json, context); });
}

}  // namespace host_id
