#include "delta/update/signature.hpp"

#include <sodium.h>

#include <cstdio>

#include "delta/input_error.hpp"
#include "delta/read_file.hpp"

namespace delta::update {
namespace {

void ensure_sodium() {
  if (sodium_init() < 0) throw InputError("libsodium could not be initialised");
}

// 64 hex digits on the file's first line (whitespace around them allowed).
std::array<std::uint8_t, 32> read_key(const std::string& path, const char* what) {
  const std::string text = read_whole_file(path);
  std::size_t at = 0;
  while (at < text.size() && (text[at] == ' ' || text[at] == '\t')) ++at;
  std::array<std::uint8_t, 32> key{};
  for (std::size_t i = 0; i < 64; ++i, ++at) {
    const char c = at < text.size() ? text[at] : '\0';
    const int v = c >= '0' && c <= '9'   ? c - '0'
                  : c >= 'a' && c <= 'f' ? c - 'a' + 10
                  : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                         : -1;
    if (v < 0) {
      throw InputError(path + ":1:" + std::to_string(at + 1) + ": " + what +
                       ": expected 64 hexadecimal digits (32 bytes)");
    }
    key[i / 2] = static_cast<std::uint8_t>(key[i / 2] | (v << (i % 2 == 0 ? 4 : 0)));
  }
  while (at < text.size() && (text[at] == ' ' || text[at] == '\t' || text[at] == '\r')) ++at;
  if (at < text.size() && text[at] != '\n') {
    throw InputError(path + ":1:" + std::to_string(at + 1) + ": " + what +
                     ": more than 64 hexadecimal digits");
  }
  return key;
}

}  // namespace

KeyPair generate_key_pair() {
  ensure_sodium();
  KeyPair k;
  randombytes_buf(k.seed.data(), k.seed.size());
  k.public_key = public_key_of(k.seed);
  return k;
}

PublicKey public_key_of(const SecretSeed& seed) {
  ensure_sodium();
  PublicKey pk{};
  std::array<std::uint8_t, crypto_sign_SECRETKEYBYTES> sk{};
  crypto_sign_seed_keypair(pk.data(), sk.data(), seed.data());
  sodium_memzero(sk.data(), sk.size());
  return pk;
}

Signature sign(std::span<const std::uint8_t> message, const SecretSeed& seed) {
  ensure_sodium();
  PublicKey pk{};
  std::array<std::uint8_t, crypto_sign_SECRETKEYBYTES> sk{};
  crypto_sign_seed_keypair(pk.data(), sk.data(), seed.data());
  Signature s{};
  crypto_sign_detached(s.data(), nullptr, message.data(), message.size(), sk.data());
  sodium_memzero(sk.data(), sk.size());
  return s;
}

bool verify(std::span<const std::uint8_t> message, const Signature& signature,
            const PublicKey& key) {
  ensure_sodium();
  return crypto_sign_verify_detached(signature.data(), message.data(), message.size(),
                                     key.data()) == 0;
}

PublicKey read_public_key(const std::string& path) {
  return read_key(path, "public key");
}
SecretSeed read_secret_seed(const std::string& path) {
  return read_key(path, "secret key");
}

std::string key_text(std::span<const std::uint8_t> key) {
  std::string s;
  char b[3];
  for (const std::uint8_t v : key) {
    std::snprintf(b, sizeof b, "%02x", v);
    s += b;
  }
  return s + "\n";
}

}  // namespace delta::update
