#include "public_key_store.hpp"

#include <filesystem>

#include "delta/atomic_file.hpp"
#include "delta/input_error.hpp"
#include "delta/read_file.hpp"

namespace fw_linux::boot {

namespace up = delta::update;

std::string fingerprint(const up::PublicKey& k) {
  return up::key_text(k).substr(0, 16);
}

void install_public_key(const std::string& state_folder, const up::PublicKey& k) {
  delta::write_file_atomically(state_folder + "/public.key", up::key_text(k), 0644);
}

namespace {

std::string retired_path(const std::string& state_folder) {
  return state_folder + "/retired.keys";
}

}  // namespace

void retire_public_key(const std::string& state_folder, const up::PublicKey& k) {
  const std::string path = retired_path(state_folder);
  const std::string list = std::filesystem::exists(path) ? delta::read_whole_file(path) : "";
  delta::write_file_atomically(path, list + up::key_text(k), 0644);
}

bool is_retired(const std::string& state_folder, const up::PublicKey& k) {
  const std::string path = retired_path(state_folder);
  return std::filesystem::exists(path) &&
         delta::read_whole_file(path).find(up::key_text(k)) != std::string::npos;
}

std::optional<up::PublicKey> settle_public_key(const std::string& state_folder,
                                               const KeyArguments& a, std::ostream& log) {
  const std::string path = state_folder + "/public.key";
  std::optional<up::PublicKey> installed;
  if (std::filesystem::exists(path)) installed = up::read_public_key(path);
  if (!a.replacement.empty()) {
    const up::PublicKey next = up::read_public_key(a.replacement);
    if (!a.given.empty() && up::read_public_key(a.given) != next) {
      throw delta::InputError("--public-key " + a.given + " and --replace-public-key " +
                              a.replacement + " are different keys: give the new key once");
    }
    if (installed) retire_public_key(state_folder, *installed);
    install_public_key(state_folder, next);
    // The slots' images an earlier key vouched for start no more.
    std::filesystem::remove(state_folder + "/vouched.sha256");
    log << "delta_boot: " << path << ": public key "
        << (installed ? "replaced (" + fingerprint(*installed) + "... by " : "installed (")
        << fingerprint(next) << "...) from " << a.replacement
        << " by the local procedure; every image must be signed with its secret key\n";
    return next;
  }
  if (!a.given.empty()) {
    const up::PublicKey given = up::read_public_key(a.given);
    if (installed && *installed != given && is_retired(state_folder, given)) {
      log << "delta_boot: --public-key " << a.given << " (" << fingerprint(given)
          << "...) was replaced by the installed key " << fingerprint(*installed)
          << "..., which holds; drop the option or give the installed key\n";
      return installed;
    }
    if (installed && *installed != given) {
      throw delta::InputError(
          path + " holds public key " + fingerprint(*installed) + "..., and --public-key " +
          a.given + " is another (" + fingerprint(given) +
          "...): an installed key is replaced only by a key image signed with it, or on the "
          "controller itself with delta_boot --replace-public-key FILE (docs/security.md)");
    }
    if (!installed) {
      install_public_key(state_folder, given);
      log << "delta_boot: installed public key " << fingerprint(given) << "... in " << path
          << ": from now on every image must be signed with its secret key, with or without "
             "--public-key (replacing it: docs/security.md)\n";
    }
    return given;
  }
  if (installed) {
    log << "delta_boot: images must be signed with the public key installed in " << path << " ("
        << fingerprint(*installed) << "...)\n";
  }
  return installed;
}

}  // namespace fw_linux::boot
