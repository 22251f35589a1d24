// host_id image make|info|sign|keygen: firmware images (docs/flashing.md).
#include <sys/stat.h>

#include <charconv>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>
#include <sstream>
#include <string>

#include "commands/command.hpp"
#include "delta/atomic_file.hpp"
#include "delta/can/protocol.hpp"
#include "delta/read_file.hpp"
#include "delta/update/image_file.hpp"

namespace host_id {

namespace {

namespace up = delta::update;

// Exit status of info for an image that fails its checks.
constexpr int kExitInvalidImage = 5;

struct MakeOptions {
  std::string program;
  std::string out;
  std::string version;
  std::string build_id;
  std::string vendor{hex32(delta::can::protocol::kControllerVendorId)};
  std::string product{hex32(delta::can::protocol::kControllerProductCode)};
  std::string revision;  // default: MAJOR << 16 | MINOR, as delta_fw reports it
  bool key{false};       // `program` is a public key file: a key image
};

std::uint32_t parse_u32(const std::string& option, const std::string& text) {
  const bool hex = text.rfind("0x", 0) == 0 || text.rfind("0X", 0) == 0;
  const char* begin = text.data() + (hex ? 2 : 0);
  std::uint32_t v = 0;
  const auto r = std::from_chars(begin, text.data() + text.size(), v, hex ? 16 : 10);
  if (begin == text.data() + text.size() || r.ec != std::errc() ||
      r.ptr != text.data() + text.size()) {
    throw UsageError("image make: " + option + " '" + text +
                     "': expected a 32-bit number (decimal or 0x hexadecimal)");
  }
  return v;
}

void run_make(const MakeOptions& o, CommandContext& context) {
  up::ImageFields f;
  f.version = up::parse_version(o.version);
  f.identity.vendor_id = parse_u32("--vendor", o.vendor);
  f.identity.product_code = parse_u32("--product", o.product);
  f.identity.revision = o.revision.empty()
                            ? (std::uint32_t{f.version.major} << 16) | f.version.minor
                            : parse_u32("--revision", o.revision);
  f.build_id = o.build_id;
  if (o.key) {
    const up::PublicKey key = up::read_public_key(o.program);
    const std::vector<std::uint8_t> image = up::make_key_image(f, key);
    delta::write_file_atomically(o.out,
                                 {reinterpret_cast<const char*>(image.data()), image.size()});
    context.out << o.out << ": a key image of public key " << up::key_text(key).substr(0, 16)
                << "..., version " << up::version_text(f.version)
                << "; sign it with the installed key's secret (host_id image sign IMAGE --key "
                   "OLD.key) and flash it (docs/security.md)\n";
    context.exit_code = 0;
    return;
  }
  const delta::FileBytes program = delta::read_file_bytes(o.program);
  const std::string_view p = program.view();
  const std::vector<std::uint8_t> image =
      up::make_image(f, {reinterpret_cast<const std::uint8_t*>(p.data()), p.size()});
  delta::write_file_atomically(o.out, {reinterpret_cast<const char*>(image.data()), image.size()});
  context.out << o.out << ": " << p.size() << " bytes of program, version "
              << up::version_text(f.version) << ", CRC-32 "
              << hex32(up::crc32({image.data() + up::kHeaderBytes, p.size()})) << "\n";
  context.exit_code = 0;
}

std::string sha_text(const up::Sha256Digest& d) {
  return up::key_text(d).substr(0, 64);
}

// image info --json: the header and the checks.
nlohmann::json info_json(const std::string& path, const up::CheckedImage& c, bool key,
                         up::Verdict signature, up::Verdict verdict) {
  const up::ImageHeader& h = *c.header;
  return {{"image", path},
          {"bytes", c.bytes.size()},
          {"vendor_id", h.identity.vendor_id},
          {"product_code", h.identity.product_code},
          {"revision", h.identity.revision},
          {"version", up::version_text(h.version)},
          {"build_id", up::build_id_text(h)},
          {"program_bytes", h.payload_bytes},
          {"program_crc32", hex32(h.payload_crc32)},
          {"program_sha256", sha_text(h.payload_sha256)},
          {"key_image", h.is_public_key()},
          {"signature", !h.is_signed()                  ? "none"
                        : !key                          ? "not verified"
                        : signature == up::Verdict::kOk ? "verified"
                                                        : "does not verify"},
          {"check", up::describe(verdict)},
          {"ok", verdict == up::Verdict::kOk}};
}

void run_info(const std::string& path, const std::string& key_path, bool json,
              CommandContext& context) {
  const up::CheckedImage c = up::read_image(path);
  if (!c.header) {
    context.err << "host_id image: error: " << path << ": " << up::describe(c.verdict) << "\n";
    context.exit_code = kExitInvalidImage;
    return;
  }
  const up::ImageHeader& h = *c.header;
  std::ostringstream text;  // the human form, printed unless --json
  std::ostream& out = text;
  out << "image:        " << path << " (" << c.bytes.size() << " bytes)\n"
      << "for:          vendor " << hex32(h.identity.vendor_id) << ", product "
      << hex32(h.identity.product_code) << ", revision " << hex32(h.identity.revision) << "\n"
      << "version:      " << up::version_text(h.version) << "\n"
      << "build id:     " << up::build_id_text(h) << "\n"
      << "program:      " << h.payload_bytes << " bytes, CRC-32 " << hex32(h.payload_crc32) << "\n"
      << "kind:         "
      << (!h.is_public_key() ? std::string("firmware")
          : up::key_of(c)
              ? "key image: public key " + up::key_text(*up::key_of(c)).substr(0, 16) + "..."
              : std::string("key image, but not a 32-byte key"))
      << "\n"
      << "SHA-256:      " << sha_text(h.payload_sha256) << "\n";
  std::optional<up::PublicKey> key;
  if (!key_path.empty()) key = up::read_public_key(key_path);
  const up::Verdict signature =
      up::check_signature(std::span(c.bytes).first(up::kHeaderBytes), h, key);
  out << "signature:    "
      << (!h.is_signed()                  ? "none"
          : !key                          ? "Ed25519 (not verified: give --public-key)"
          : signature == up::Verdict::kOk ? "Ed25519, verified"
                                          : "Ed25519, DOES NOT VERIFY")
      << "\n";
  const up::Verdict verdict = c.verdict != up::Verdict::kOk ? c.verdict : signature;
  if (json) {
    context.out << info_json(path, c, key.has_value(), signature, verdict).dump(2) << "\n";
  } else {
    out << "check:        " << up::describe(verdict) << "\n";
    context.out << text.str();
  }
  if (verdict != up::Verdict::kOk) {
    context.err << "host_id image: error: " << path << ": " << up::describe(verdict) << "\n";
  }
  context.exit_code = verdict == up::Verdict::kOk ? 0 : kExitInvalidImage;
}

void run_sign(const std::string& path, const std::string& key_path, const std::string& out_path,
              CommandContext& context) {
  const up::SecretSeed seed = up::read_secret_seed(key_path);
  const delta::FileBytes file = delta::read_file_bytes(path);
  const std::string_view v = file.view();
  const std::vector<std::uint8_t> signed_image =
      up::sign_image({reinterpret_cast<const std::uint8_t*>(v.data()), v.size()}, seed);
  const std::string target = out_path.empty() ? path : out_path;
  delta::write_file_atomically(
      target, {reinterpret_cast<const char*>(signed_image.data()), signed_image.size()});
  context.out << target << ": signed with the key of public key "
              << up::key_text(up::public_key_of(seed));
  context.exit_code = 0;
}

void run_keygen(const std::string& secret_path, const std::string& public_path,
                CommandContext& context) {
  struct stat st {};
  if (::stat(secret_path.c_str(), &st) == 0) {
    throw UsageError("image keygen: " + secret_path + " exists; not overwriting a secret key");
  }
  const up::KeyPair k = up::generate_key_pair();
  // Both or neither; the secret readable by its owner only.
  delta::AtomicFileWriter secret(secret_path, 0600), public_key(public_path);
  secret.write(up::key_text(k.seed));
  public_key.write(up::key_text(k.public_key));
  delta::commit_together({&secret, &public_key});
  context.out << "secret key: " << secret_path << " (keep it off the controller)\n"
              << "public key: " << public_path
              << " (verifies signatures: host_id image info --public-key)\n";
  context.exit_code = 0;
}

}  // namespace

// image key: a key image of the next public key.
void add_key_subcommand(CLI::App& c, CommandContext& context) {
  auto key = std::make_shared<MakeOptions>();
  key->key = true;
  CLI::App* ki =
      c.add_subcommand("key",
                       "write a key image: the controller's next public key, to be signed with the "
                       "installed key's secret (docs/security.md)");
  ki->add_option("PUBLIC_KEY", key->program, "the next public key file (host_id image keygen)")
      ->required();
  ki->add_option("-o,--out", key->out, "the image to write (atomically)")
      ->check(kOutputPath)
      ->required();
  ki->add_option("--version", key->version, "a version for the record, MAJOR.MINOR.PATCH")
      ->required();
  ki->add_option("--vendor", key->vendor, "the vendor ID (0x1018:1)")->capture_default_str();
  ki->add_option("--product", key->product, "the product code (0x1018:2)")->capture_default_str();
  ki->callback([key, &context] { run_make(*key, context); });
}

void add_image_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Firmware images for 'host_id flash' (docs/flashing.md): a 256-byte header (the hardware "
      "it is for, the version, the program's length, CRC-32 and SHA-256, an optional Ed25519 "
      "signature) and the program. Exit status 5: the image fails its checks.");
  c->require_subcommand(1);

  auto make = std::make_shared<MakeOptions>();
  CLI::App* m = c->add_subcommand("make", "write an image of a program");
  m->add_option("PROGRAM", make->program, "the program (for delta_fw: its executable)")->required();
  m->add_option("-o,--out", make->out, "the image to write (atomically)")
      ->check(kOutputPath)
      ->required();
  m->add_option("--version", make->version, "the program's version, MAJOR.MINOR.PATCH")->required();
  m->add_option("--build-id", make->build_id, "up to 32 characters, e.g. a git commit");
  m->add_option("--vendor", make->vendor, "the vendor ID (0x1018:1)")->capture_default_str();
  m->add_option("--product", make->product, "the product code (0x1018:2)")->capture_default_str();
  m->add_option("--revision", make->revision,
                "the revision the program reports (0x1018:3); default MAJOR<<16 | MINOR");
  m->callback([make, &context] { run_make(*make, context); });

  add_key_subcommand(*c, context);

  auto info_path = std::make_shared<std::string>();
  auto info_key = std::make_shared<std::string>();
  auto info_json = std::make_shared<bool>(false);
  CLI::App* i = c->add_subcommand("info", "print an image's header and check it");
  i->add_option("IMAGE", *info_path, "the image")->required();
  i->add_option("--public-key", *info_key, "verify the signature with this public key file");
  i->add_flag("--json", *info_json, "the header and the checks as JSON on stdout");
  i->callback([info_path, info_key, info_json, &context] {
    run_info(*info_path, *info_key, *info_json, context);
  });

  auto sign_path = std::make_shared<std::string>();
  auto sign_key = std::make_shared<std::string>();
  auto sign_out = std::make_shared<std::string>();
  CLI::App* s = c->add_subcommand("sign", "sign an image (Ed25519)");
  s->add_option("IMAGE", *sign_path, "the image")->required();
  s->add_option("--key", *sign_key, "the secret key file (host_id image keygen)")->required();
  s->add_option("-o,--out", *sign_out, "write the signed image here (default: in place)")
      ->check(kOutputPath);
  s->callback([=, &context] { run_sign(*sign_path, *sign_key, *sign_out, context); });

  auto secret = std::make_shared<std::string>();
  auto pub = std::make_shared<std::string>();
  CLI::App* k = c->add_subcommand("keygen", "make an Ed25519 key pair for signing images");
  k->add_option("--secret", *secret, "the secret key file to write (mode 0600)")->required();
  k->add_option("--public", *pub, "the public key file to write")->required();
  k->callback([=, &context] { run_keygen(*secret, *pub, context); });
}

}  // namespace host_id
