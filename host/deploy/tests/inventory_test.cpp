// The deploy inventory of rig.toml and the edge.toml it makes for each board, read back with
// voxcap-edge's own reader.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "config.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/deploy/deploy.hpp"
#include "voxcap/deploy/inventory.hpp"

namespace vc::deploy {
namespace {

const std::filesystem::path kRigs = std::filesystem::path(VOXCAP_SOURCE_DIR) / "hw" / "rigs";

edge::EdgeSettings parse_edge(const std::string& text) {
  edge::EdgeSettings s;
  edge::parse_edge_toml(text, "edge.toml", s);
  s.validate();
  return s;
}

// A copy of the reference rig in a temporary folder with `extra` appended to its text.
std::filesystem::path rig_copy(const std::string& name, const std::string& replace_from = "",
                               const std::string& replace_to = "") {
  const auto dir = std::filesystem::temp_directory_path() / ("vc_deploy_inv_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::filesystem::copy_file(kRigs / "pi5-reference.yaml", dir / "pi5-reference.yaml");
  std::ifstream in(kRigs / "pi5-reference.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!replace_from.empty()) {
    const size_t at = text.find(replace_from);
    EXPECT_NE(at, std::string::npos) << replace_from;
    if (at != std::string::npos) text.replace(at, replace_from.size(), replace_to);
  }
  std::ofstream(dir / "rig.toml") << text;
  return dir / "rig.toml";
}

TEST(Inventory, ReferenceRigGivesEveryBoardAnEdgeTomlTheEdgeAccepts) {
  const Inventory inv = load_inventory(kRigs / "pi5-reference.toml");
  ASSERT_EQ(inv.boards.size(), 3u);
  EXPECT_EQ(inv.parallel, 3);
  EXPECT_EQ(inv.hello_timeout_s, 20);  // the default: each board's HELLO awaited when deploy can listen
  EXPECT_EQ(inv.host_address, "192.168.50.1");
  const Board& b = inv.boards[1];
  EXPECT_EQ(b.id, "pi-b");
  EXPECT_EQ(b.number, 2);
  EXPECT_EQ(b.settings.ssh, "voxcap-admin@192.168.50.12");
  EXPECT_EQ(b.settings.known_hosts, (kRigs / "known_hosts").lexically_normal());
  EXPECT_EQ(b.settings.service, "voxcap-edge.service");
  const edge::EdgeSettings s = parse_edge(b.edge_toml);
  EXPECT_EQ(s.node_id, 2);
  EXPECT_EQ(s.key, "rig.key");
  EXPECT_EQ(s.host, "192.168.50.1");
  EXPECT_EQ(s.port, 7600);
  EXPECT_EQ(s.cameras[0].index, 2);
  EXPECT_EQ(s.cameras[1].index, 3);
  for (const auto& c : s.cameras) {
    EXPECT_EQ(c.backend, "libcamera");
    EXPECT_EQ(c.width, 1456);
    EXPECT_EQ(c.height, 1088);
    EXPECT_TRUE(c.external_trigger);
  }
  EXPECT_EQ(s.cameras[1].device, "1");
  EXPECT_EQ(s.trigger_backend, "gpiod");
  EXPECT_EQ(s.gpio_line, 17);
  EXPECT_TRUE(s.gpio_active_low);  // the rig's trigger.active_low
  EXPECT_EQ(s.state_dir, "/var/lib/voxcap");
}

TEST(Inventory, NodeOverridesMergeOverTheRigWideTemplate) {
  const auto p = rig_copy("override", "id = \"pi-c\"\n",
                          "id = \"pi-c\"\ndeploy = { ssh_port = 2222, root = \"/srv/board\", "
                          "edge = { cameras = [{}, { device = \"7\" }], trigger = { line = 27 } } }\n");
  const Inventory inv = load_inventory(p);
  const Board& c = *inv.board("pi-c");
  EXPECT_EQ(c.settings.ssh_port, 2222);
  EXPECT_EQ(c.settings.root, "/srv/board");
  EXPECT_EQ(inv.board("pi-a")->settings.ssh_port, 22);
  const edge::EdgeSettings s = parse_edge(c.edge_toml);
  EXPECT_EQ(s.cameras[0].device, "0");  // the template's
  EXPECT_EQ(s.cameras[1].device, "7");  // the node's
  EXPECT_EQ(s.cameras[1].width, 1456);
  EXPECT_EQ(s.gpio_line, 27);
  EXPECT_EQ(parse_edge(inv.board("pi-a")->edge_toml).gpio_line, 17);
}

TEST(Inventory, BadKeysAreNamed) {
  try {
    load_inventory(rig_copy("typo", "parallel = 3", "paralel = 3"));
    FAIL() << "a typo in [deploy] loaded";
  } catch (const InventoryError& e) {
    EXPECT_NE(std::string(e.what()).find("deploy.paralel: unknown key"), std::string::npos) << e.what();
  }
  try {
    load_inventory(rig_copy("edgebad", "line = 17 ", "line = -4 "));
    FAIL() << "an edge.toml the edge refuses loaded";
  } catch (const InventoryError& e) {
    EXPECT_NE(std::string(e.what()).find("refused by voxcap-edge"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("trigger.line"), std::string::npos) << e.what();
  }
  try {
    load_inventory(rig_copy("hostaddr", "host_address = \"192.168.50.1\"", ""));
    FAIL() << "no host address and network.listen any loaded";
  } catch (const InventoryError& e) {
    EXPECT_NE(std::string(e.what()).find("deploy.host_address: missing"), std::string::npos) << e.what();
  }
  EXPECT_EQ(
      load_inventory(rig_copy("hello0", "parallel = 3", "parallel = 3\nhello_timeout_s = 0")).hello_timeout_s,
      0);
  try {
    load_inventory(rig_copy("hellobad", "parallel = 3", "parallel = 3\nhello_timeout_s = 601"));
    FAIL() << "hello_timeout_s 601 loaded";
  } catch (const InventoryError& e) {
    EXPECT_NE(std::string(e.what()).find("deploy.hello_timeout_s"), std::string::npos) << e.what();
  }
  try {
    load_inventory(rig_copy("sshbad", "ssh = \"voxcap-admin@192.168.50.11\"", "ssh = \"-oProxyCommand=x\""));
    FAIL() << "an option as ssh target loaded";
  } catch (const InventoryError& e) {
    EXPECT_NE(std::string(e.what()).find("nodes[0].ssh"), std::string::npos) << e.what();
  }
}

TEST(Inventory, TheHostStillReadsTheRigFile) {
  // voxcap config check and the host take the deploy keys without using them.
  const config::RigConfig c = config::load_rig_config(kRigs / "pi5-reference.toml");
  EXPECT_EQ(c.nodes.size(), 3u);
  EXPECT_EQ(c.trigger.backend, config::TriggerBackend::Ftdi);
  EXPECT_TRUE(c.trigger.active_low);
}

TEST(Package, UpstreamVersion) {
  EXPECT_EQ(upstream_version("0.1.0"), "0.1.0");
  EXPECT_EQ(upstream_version("0.1.0-1"), "0.1.0");
  EXPECT_EQ(upstream_version("2:0.3.1-2~bpo12+1"), "0.3.1");
}

}  // namespace
}  // namespace vc::deploy
