// voxcap key new FILE [--force] | voxcap key check FILE: the rig key of authenticated control
// (proto/SPEC.md "Authentication"). The key is 32 random bytes (libsodium's randombytes_buf) written
// as one line of 64 hex digits with mode 0600; rig.toml and every edge.toml name it (`key = "..."`).
#include <fmt/core.h>

#include <string>

#include "commands.hpp"
#include "voxcap/auth.h"

namespace vc::cli {

void add_key_commands(CLI::App& app) {
  CLI::App* key = app.add_subcommand("key", "the rig key that host and edges prove to each other");
  key->require_subcommand(1);

  CLI::App* make = key->add_subcommand(
      "new",
      "write a fresh rig key (32 random bytes, one line of hex, mode 0600) to FILE; name it in rig.toml and "
      "every edge.toml as key = \"FILE\" (relative to that file), or give it to voxcap-edge --key");
  auto path = std::make_shared<std::string>();
  auto force = std::make_shared<bool>(false);
  make->add_option("FILE", *path, "the key file to create")->required();
  make->add_flag("--force", *force, "replace an existing file (its old key stops working)");
  make->callback([path, force] {
    if (vc_auth_init() < 0) throw std::runtime_error("libsodium failed to start");
    char why[512];
    if (vc_key_write(path->c_str(), *force, nullptr, why, sizeof why) < 0) throw UsageError(why);
    fmt::print("wrote a new rig key to {} (mode 0600)\n", *path);
  });

  CLI::App* check = key->add_subcommand(
      "check",
      "read FILE as host and edges do: exit 2 with the reason if it is not one line of 64 hex digits "
      "or if group or others may read it");
  auto cpath = std::make_shared<std::string>();
  check->add_option("FILE", *cpath, "the key file")->required();
  check->callback([cpath] {
    uint8_t k[VC_AUTH_KEY_SIZE];
    char why[512];
    if (vc_key_load(cpath->c_str(), k, why, sizeof why) < 0) throw UsageError(why);
    fmt::print("{}: a valid rig key\n", *cpath);
  });
}

}  // namespace vc::cli
