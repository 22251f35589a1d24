// delta_boot: the controller's supervisor with A/B program slots, trial boot
// and roll-back (docs/flashing.md).
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "delta/input_error.hpp"
#include "public_key_store.hpp"
#include "supervisor.hpp"

namespace {

namespace boot = fw_linux::boot;
namespace up = delta::update;

constexpr const char* kDescription =
    "Runs the controller's program from the active one of two slots in STATE_DIR, and a newly "
    "downloaded program on trial until it confirms; rolls back to the previous slot when the new "
    "one does not confirm within --trial-timeout, exits or crashes. Arguments after -- go to the "
    "program (delta_fw). Exit codes: the program's own when it ends, 2 usage, 7 no slot holds a "
    "program that starts (install one with --install).";

struct Arguments {
  std::string state_dir;
  std::string install;
  boot::KeyArguments keys;
  double trial_timeout_s{30};
  std::uint32_t capacity_mib{64};
  std::vector<std::string> program_arguments;
};

std::optional<int> parse(int argc, char** argv, Arguments& a) {
  CLI::App app(kDescription, "delta_boot");
  app.add_option("--state-dir", a.state_dir, "the folder of the slots and their record")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--install", a.install,
                 "an image to install in slot 0 when STATE_DIR holds no program yet")
      ->check(CLI::ExistingFile);
  app.add_option("--public-key", a.keys.given,
                 "accept only images signed with this key (host_id image keygen); the first "
                 "one given is installed in STATE_DIR/public.key and holds from then on, "
                 "given or not; another key is refused (docs/security.md)")
      ->check(CLI::ExistingFile);
  app.add_option("--replace-public-key", a.keys.replacement,
                 "the local procedure: install this key in place of STATE_DIR/public.key "
                 "(docs/security.md)")
      ->check(CLI::ExistingFile);
  app.add_option("--trial-timeout", a.trial_timeout_s,
                 "seconds a new program has to confirm itself")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  app.add_option("--capacity-mib", a.capacity_mib, "the largest image a slot takes, MiB")
      ->check(CLI::Range(1, 2047))
      ->capture_default_str();
  app.add_option("program_arguments", a.program_arguments, "-- then the program's arguments");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "delta_boot: " << e.what() << " (see delta_boot --help)\n";
    return boot::kExitUsage;
  }
  return std::nullopt;
}

// The record, or a first one when the folder is empty and --install names
// an image; nothing (with the reason said) when there is no program.
std::optional<fw::update::BootRecord> record_to_boot(const boot::SlotStore& store,
                                                     const Arguments& a) {
  if (auto r = store.load_record()) {
    if (!a.install.empty()) {
      std::cerr << "delta_boot: " << a.state_dir << " holds a program already; --install "
                << a.install << " is ignored (flash a new one with host_id flash)\n";
    }
    return r;
  }
  if (a.install.empty()) {
    std::cerr << "delta_boot: " << a.state_dir
              << " holds no program: give one with --install IMAGE\n";
    return std::nullopt;
  }
  const boot::SlotImage image = store.install(a.install, 0);
  if (image.verdict != up::Verdict::kOk) {
    std::cerr << "delta_boot: " << a.install << ": " << up::describe(image.verdict) << "\n";
    return std::nullopt;
  }
  fw::update::BootRecord r;
  r.slots[0] = {fw::update::SlotState::kConfirmed, image.crc32, image.version};
  store.save_record(r);
  std::cerr << "delta_boot: installed " << a.install << " (version "
            << up::version_text(image.version) << ") in slot 0\n";
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  Arguments a;
  if (const auto code = parse(argc, argv, a)) return *code;
  const std::string folder = std::filesystem::absolute(a.state_dir).string();
  boot::SupervisorOptions options;
  try {
    options.public_key = boot::settle_public_key(folder, a.keys, std::cerr);
  } catch (const delta::InputError& e) {
    std::cerr << "delta_boot: " << e.what() << "\n";
    return boot::kExitUsage;
  }
  try {
    options.program_arguments = a.program_arguments;
    options.trial_timeout =
        std::chrono::milliseconds(static_cast<std::int64_t>(a.trial_timeout_s * 1000));
    options.capacity_bytes = a.capacity_mib << 20;
    boot::SlotStore store(folder, options.public_key);
    const auto record = record_to_boot(store, a);
    if (!record) return boot::kExitNoProgram;
    boot::Supervisor supervisor(store, *record, options, std::cerr);
    return supervisor.run();
  } catch (const delta::InputError& e) {
    std::cerr << "delta_boot: " << e.what() << "\n";
    return boot::kExitNoProgram;
  }
}
