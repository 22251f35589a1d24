// The controller's public key, installed once in delta_boot's state folder
// as `public.key` (docs/security.md). Once it is there every image must be
// signed with its secret key, whether delta_boot is given --public-key or
// not; another key is refused, and it is replaced only by a key image
// signed with it (Supervisor) or by the local procedure
// (--replace-public-key, run on the controller).
#pragma once

#include <optional>
#include <ostream>
#include <string>

#include "delta/update/signature.hpp"

namespace fw_linux::boot {

struct KeyArguments {
  std::string given;        // --public-key FILE ("" none)
  std::string replacement;  // --replace-public-key FILE ("" none)
};

// The key delta_boot checks images with, after installing or replacing it
// as asked (each said on `log`); nothing where none is given or installed.
// Throws delta::InputError (naming the files and what to do) for a given
// key that is not the installed one, a replacement beside another
// --public-key, and an unreadable key file.
std::optional<delta::update::PublicKey> settle_public_key(const std::string& state_folder,
                                                          const KeyArguments& a, std::ostream& log);

// `key` into STATE_FOLDER/public.key (atomically).
void install_public_key(const std::string& state_folder, const delta::update::PublicKey& key);
// A key the installed one replaced (STATE_FOLDER/retired.keys): a
// --public-key that names it is taken as the installed key's, with a note,
// so that a service file written before the replacement still starts.
void retire_public_key(const std::string& state_folder, const delta::update::PublicKey& key);
bool is_retired(const std::string& state_folder, const delta::update::PublicKey& key);
// The key's first 16 hexadecimal digits: enough to tell two apart in a log.
std::string fingerprint(const delta::update::PublicKey& key);

}  // namespace fw_linux::boot
