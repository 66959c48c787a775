// The deploy inventory: what `voxcap deploy` needs beyond the rig itself, read from the same rig.toml
// (its [deploy] table and each [[nodes]]'s `ssh` and [nodes.deploy] keys), and each board's edge.toml
// generated from it. Layout and defaults: host/deploy/README.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "voxcap/config/rig_config.hpp"

namespace vc::deploy {

// Bad inventory: one line naming the file and the key.
struct InventoryError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// How to reach one board and what it looks like inside: [deploy], then the node's [nodes.deploy].
struct BoardSettings {
  std::string ssh;       // ssh target "user@host" or "host" (nodes[].ssh; default ssh_user@address)
  std::string ssh_user;  // login for nodes without `ssh` ("" = ssh's default)
  int ssh_port = 22;
  std::filesystem::path identity;         // ssh -i (absolute; empty: ssh's default keys)
  std::filesystem::path known_hosts;      // UserKnownHostsFile (absolute; empty: ~/.ssh/known_hosts)
  std::string host_key_checking = "yes";  // StrictHostKeyChecking: "yes" | "accept-new"
  int connect_timeout_s = 10;             // ssh ConnectTimeout
  int step_timeout_s = 300;               // one step on a board (copy + install) at most
  std::string sudo = "sudo -n";           // how root commands run on the board ("" = already root)
  std::string dpkg = "dpkg";              // installer: `$dpkg -i FILE.deb`
  std::string systemctl = "systemctl";
  std::string root;                     // prefix of every path on the board ("" = /): staging and tests
  std::string service_user = "voxcap";  // owns the rig key on the board
  std::string service = "voxcap-edge.service";
  double settle_s = 3;  // after a restart, wait this long before checking the service

  bool valid(std::string* why) const;
};

// One board: its rig node, how to reach it and the edge.toml it gets.
struct Board {
  std::string id;       // nodes[].id
  uint16_t number = 0;  // the protocol's node id (edge.toml node_id)
  std::string address;  // nodes[].address
  BoardSettings settings;
  std::string edge_toml;  // generated, checked with the edge's own parser
};

// What flash-config needs besides the board ([deploy] keys only it reads).
struct FlashSettings {
  std::string admin_user;  // the login user created on first boot (default: ssh_user or "voxcap-admin")
  std::filesystem::path authorized_key;  // public key file for admin_user (absolute; or --ssh-key)
  std::string
      package_repo;  // apt line's URL of a local repo holding voxcap-edge ("" = a .deb on the boot partition)
  int network_prefix = 24;       // the board's static address: nodes[].address/prefix on eth0
  std::string gateway;           // optional
  std::vector<std::string> dns;  // optional
  std::string timezone;          // optional, e.g. "Europe/Berlin"
};

struct Inventory {
  config::RigConfig rig;
  std::string host_address;  // what the boards connect to ([deploy] host_address, or network.listen)
  int parallel = 4;          // boards worked on at once
  // How long a restarted board has to send its HELLO to deploy's listener on the rig's port (when
  // deploy can take that port: no voxcap-host runs); 0 = do not listen.
  int hello_timeout_s = 20;
  std::filesystem::path package;  // [deploy] package (absolute), the default of --package
  FlashSettings flash;
  std::vector<Board> boards;  // in rig node order

  const Board* board(const std::string& id) const;  // nullptr if absent
};

// Reads rig.toml as the host does (load_rig_config), then its deploy keys; generates and checks every
// board's edge.toml. Throws config::ConfigError or InventoryError (one line naming the key).
Inventory load_inventory(const std::filesystem::path& rig_toml);

// The edge.toml of one node: [deploy.edge] with the node's [nodes.deploy.edge] over it, and what the
// rig decides (node_id, key, host address and port, camera indices and sizes, trigger polarity) set
// from the rig. Checked with voxcap-edge's own reader; throws InventoryError with its message.
std::string make_edge_toml(const config::RigConfig& rig, size_t node_index, const std::string& host_address,
                           const std::string& edge_template_toml, const std::string& node_edge_toml);

// Parses an edge.toml with voxcap-edge's own reader and checks it as the daemon does before it opens
// any device (EdgeSettings::validate). "" when it is good, else the edge's one-line reason.
std::string check_edge_toml(const std::string& text, const std::string& name);

}  // namespace vc::deploy
