// `voxcap deploy`: every board of the rig over ssh, at most Inventory::parallel at once. Per board:
// probe (the version it runs) → install (the rig key and edge.toml written beside the old ones, the
// package installed, the service restarted) → verify (the service is active after settle_s, the
// binary says the package's version, and it proves the rig key over a fresh nonce) → on any failure
// roll back to the kept package, edge.toml and key, restart and verify the old state. Key rotation:
// host/deploy/README.md "Keys".
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "voxcap/deploy/inventory.hpp"
#include "voxcap/deploy/remote.hpp"

namespace vc::deploy {

struct DeployOptions {
  std::filesystem::path
      package;              // the voxcap-edge .deb ("" = Inventory::package, or none: config and key only)
  bool rotate_key = false;  // a new rig key for every board, then for the host (README "Keys")
  bool dry_run = false;     // probe every board and print the plan; change nothing
  std::vector<std::string> nodes;  // only these boards (empty: all)

  bool valid(std::string* why) const;
};

enum class KeyState { Unknown, Current, New, Old };  // what the board proved after the run

struct BoardResult {
  std::string id;
  bool ok = false;           // the board runs what was asked for
  bool rolled_back = false;  // it failed and was put back
  bool rollback_ok = false;  // ... and came back with its previous version
  std::string before;        // version found before ("none" if no voxcap-edge)
  std::string after;         // version running at the end
  KeyState key = KeyState::Unknown;
  std::string hello;  // the version its HELLO said after the restart ("" = not checked)
  std::string why;    // the failure, one line
};

struct DeployReport {
  std::string package_version;  // the package's upstream version ("" without a package)
  std::vector<BoardResult> boards;
  bool key_switched = false;       // --rotate-key: the host's key file now holds the new key
  std::filesystem::path key_next;  // --rotate-key: the pending new key, while not every board proved it
  std::vector<std::string> left_with_old_key;  // --rotate-key: boards that did not prove the new key
  std::string hello_note;                      // whether deploy listened for the boards' HELLO, or why not
  bool ok() const;
};

// A package's name and upstream version (`dpkg-deb -f`; Debian's revision and epoch dropped).
struct PackageInfo {
  std::string name, version, upstream;
};
PackageInfo read_package(const std::filesystem::path& deb);
// "1:0.2.0-3" → "0.2.0"
std::string upstream_version(const std::string& debian_version);

// One line of progress: board id ("" for the whole run) and what happens.
using Progress = std::function<void(const std::string& board, const std::string& line)>;

// Runs the deploy; throws InventoryError or std::runtime_error for what stops it before any board is
// touched (bad package, unreadable key). Board failures are in the report.
DeployReport run_deploy(const Inventory& inv, const DeployOptions& opt, Remote& remote,
                        const Progress& progress);

// The summary table printed at the end.
std::string format_summary(const DeployReport& r, bool rotate_key);

}  // namespace vc::deploy
