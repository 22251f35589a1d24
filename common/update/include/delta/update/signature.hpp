// Ed25519 signatures of firmware images (libsodium). A key file is one line
// of hexadecimal: a secret key file holds the 32-byte seed, a public key
// file the 32-byte public key (docs/flashing.md). Keep the secret file
// readable by its owner only; host_id image keygen writes it so.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "delta/update/image.hpp"

namespace delta::update {

using PublicKey = std::array<std::uint8_t, 32>;
using SecretSeed = std::array<std::uint8_t, 32>;

struct KeyPair {
  SecretSeed seed{};
  PublicKey public_key{};
};

// A fresh key pair from the system's random source.
KeyPair generate_key_pair();
PublicKey public_key_of(const SecretSeed& seed);
Signature sign(std::span<const std::uint8_t> message, const SecretSeed& seed);
bool verify(std::span<const std::uint8_t> message, const Signature& signature,
            const PublicKey& key);

// Key files; InputError names the file and line:column of what is wrong.
PublicKey read_public_key(const std::string& path);
SecretSeed read_secret_seed(const std::string& path);
std::string key_text(std::span<const std::uint8_t> key);  // 64 hex digits and a newline

}  // namespace delta::update
