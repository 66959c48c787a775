// voxcap deploy flash-config's files, read back without booting anything: the cloud-init YAML parses
// (yaml-cpp), holds the keys a first boot needs for this node, its edge.toml passes voxcap-edge's own
// reader, the rig key is 0600 and a valid key, the camera overlay lines are there.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "config.hpp"
#include "voxcap/auth.h"
#include "voxcap/deploy/flash.hpp"
#include "voxcap/deploy/inventory.hpp"

namespace vc::deploy {
namespace {

const std::filesystem::path kRigs = std::filesystem::path(VOXCAP_SOURCE_DIR) / "hw" / "rigs";

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

struct FlashTest : ::testing::Test {
  // One folder per test: CTest runs them in parallel.
  std::filesystem::path dir = std::filesystem::temp_directory_path() /
                              (std::string("vc_deploy_flash_test_") +
                               ::testing::UnitTest::GetInstance()->current_test_info()->name());
  std::filesystem::path out = dir / "bootfs";
  void SetUp() override {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    for (const char* f : {"pi5-reference.toml", "pi5-reference.yaml"})
      std::filesystem::copy_file(kRigs / f, dir / f);
    ASSERT_EQ(vc_auth_init(), 0);
    char why[256];
    ASSERT_EQ(vc_key_write((dir / "rig.key").c_str(), false, nullptr, why, sizeof why), 0) << why;
    std::ofstream(dir / "id.pub")
        << "ssh-ed25519 AAAAC3NzaC1lZDI1NTE5AAAAIJtestkeytestkeytestkeytestkeytestkeytestkey lab@host\n";
    std::ofstream(dir / "voxcap-edge_0.1.0_arm64.deb") << "not really a package";
  }
};

TEST_F(FlashTest, FilesAreWhatAFirstBootNeeds) {
  const Inventory inv = load_inventory(dir / "pi5-reference.toml");
  FlashOptions o;
  o.node = "pi-b";
  o.out = out;
  o.ssh_key = dir / "id.pub";
  const FlashResult r = write_flash_config(inv, o);
  EXPECT_EQ(r.files.size(), 8u);  // both first-boot mechanisms by default

  // user-data: a cloud-config document.
  const std::string ud = slurp(out / "user-data");
  ASSERT_EQ(ud.rfind("#cloud-config\n", 0), 0u);
  const YAML::Node u = YAML::Load(ud);
  EXPECT_EQ(u["hostname"].as<std::string>(), "pi-b");
  EXPECT_FALSE(u["ssh_pwauth"].as<bool>());
  const YAML::Node users = u["users"];
  ASSERT_EQ(users.size(), 2u);
  EXPECT_EQ(users[0]["name"].as<std::string>(), "voxcap-admin");
  EXPECT_EQ(users[0]["ssh_authorized_keys"][0].as<std::string>(),
            slurp(dir / "id.pub").substr(0, slurp(dir / "id.pub").size() - 1));
  EXPECT_EQ(users[0]["sudo"].as<std::string>(), "ALL=(ALL) NOPASSWD:ALL");  // voxcap deploy runs sudo -n
  EXPECT_EQ(users[1]["name"].as<std::string>(), "voxcap");
  EXPECT_TRUE(users[1]["system"].as<bool>());

  // edge.toml inline, read by the edge's own parser.
  std::string edge_toml;
  bool modprobe = false;
  for (const auto& f : u["write_files"]) {
    const std::string path = f["path"].as<std::string>();
    if (path == "/etc/voxcap/edge.toml") {
      edge_toml = f["content"].as<std::string>();
      EXPECT_EQ(f["permissions"].as<std::string>(), "0644");
    }
    if (path == "/etc/modprobe.d/voxcap-imx296.conf") {
      modprobe = f["content"].as<std::string>().find("options imx296 trigger_mode=1") != std::string::npos;
    }
  }
  EXPECT_TRUE(modprobe) << "the IMX296 external trigger mode";
  ASSERT_FALSE(edge_toml.empty());
  edge::EdgeSettings s;
  ASSERT_NO_THROW(edge::parse_edge_toml(edge_toml, "edge.toml", s));
  ASSERT_NO_THROW(s.validate());
  EXPECT_EQ(s.node_id, 2);
  EXPECT_EQ(s.key, "rig.key");
  EXPECT_EQ(s.host, "192.168.50.1");
  EXPECT_EQ(s.cameras[0].index, 2);

  // runcmd: the package, the key 0600 for the service user, the config.txt include.
  std::string runcmd;
  for (const auto& c : u["runcmd"]) runcmd += c.as<std::string>() + "\n";
  EXPECT_NE(runcmd.find("apt-get install -y /boot/firmware/voxcap/voxcap-edge.deb"), std::string::npos)
      << runcmd;
  EXPECT_NE(runcmd.find("install -m 0600 -o voxcap /boot/firmware/voxcap/rig.key /etc/voxcap/rig.key"),
            std::string::npos)
      << runcmd;
  EXPECT_NE(runcmd.find("shred -u /boot/firmware/voxcap/rig.key"), std::string::npos);
  EXPECT_NE(runcmd.find("include voxcap-camera.txt"), std::string::npos);
  EXPECT_NE(runcmd.find("systemctl enable voxcap-edge.service"), std::string::npos);
  EXPECT_EQ(u["power_state"]["mode"].as<std::string>(), "reboot");

  // meta-data, network-config.
  const YAML::Node m = YAML::LoadFile((out / "meta-data").string());
  EXPECT_EQ(m["local-hostname"].as<std::string>(), "pi-b");
  EXPECT_EQ(m["instance-id"].as<std::string>().rfind("voxcap-pi-b-", 0), 0u);
  const YAML::Node n = YAML::LoadFile((out / "network-config").string());
  EXPECT_EQ(n["network"]["version"].as<int>(), 2);
  const YAML::Node eth = n["network"]["ethernets"]["eth0"];
  EXPECT_EQ(eth["addresses"][0].as<std::string>(), "192.168.50.12/24");
  EXPECT_FALSE(eth["dhcp4"].as<bool>());
  EXPECT_EQ(eth["routes"][0]["via"].as<std::string>(), "192.168.50.1");

  // The rig key on the card: 0600 and the rig's key.
  struct stat st {};
  ASSERT_EQ(::stat((out / "voxcap" / "rig.key").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  uint8_t a[VC_AUTH_KEY_SIZE], b[VC_AUTH_KEY_SIZE];
  char why[256];
  ASSERT_EQ(vc_key_load((out / "voxcap" / "rig.key").c_str(), a, why, sizeof why), 0) << why;
  ASSERT_EQ(vc_key_load((dir / "rig.key").c_str(), b, why, sizeof why), 0) << why;
  EXPECT_EQ(std::memcmp(a, b, sizeof a), 0);
  EXPECT_EQ(slurp(out / "voxcap" / "voxcap-edge.deb"), "not really a package");

  const std::string cam = slurp(out / "voxcap-camera.txt");
  EXPECT_NE(cam.find("camera_auto_detect=0\n"), std::string::npos);
  EXPECT_NE(cam.find("dtoverlay=imx296,cam0\n"), std::string::npos);
  EXPECT_NE(cam.find("dtoverlay=imx296,cam1\n"), std::string::npos);
}

// The text between "cat >PATH <<'END'" and END in a script.
std::string heredoc(const std::string& script, const std::string& path) {
  const std::string open = "cat >" + path + " <<'VOXCAP_END_OF_FILE'\n";
  const size_t at = script.find(open);
  if (at == std::string::npos) return {};
  const size_t from = at + open.size();
  const size_t to = script.find("\nVOXCAP_END_OF_FILE\n", from);
  return to == std::string::npos ? std::string() : script.substr(from, to + 1 - from);
}

// bash -n: the script parses (nothing of it runs).
int bash_syntax(const std::filesystem::path& script) {
  return std::system(("bash -n '" + script.string() + "'").c_str());
}

TEST_F(FlashTest, FirstrunScriptForBookworm) {
  const Inventory inv = load_inventory(dir / "pi5-reference.toml");
  FlashOptions o;
  o.node = "pi-b";
  o.out = out;
  o.ssh_key = dir / "id.pub";
  o.first_boot = FirstBoot::Firstrun;
  const FlashResult r = write_flash_config(inv, o);
  EXPECT_EQ(r.files.size(), 5u);
  EXPECT_FALSE(std::filesystem::exists(out / "user-data"));  // firstrun only
  const std::filesystem::path script = out / "firstrun.sh";
  ASSERT_TRUE(std::filesystem::exists(script));
  EXPECT_EQ(bash_syntax(script), 0);
  const std::string sh = slurp(script);
  EXPECT_EQ(sh.rfind("#!/bin/bash\n", 0), 0u);
  EXPECT_NE(sh.find("\nNODE='pi-b'\n"), std::string::npos);
  EXPECT_NE(sh.find("set_hostname \"$NODE\""), std::string::npos);
  EXPECT_NE(sh.find("echo \"$NODE\" >/etc/hostname"), std::string::npos);
  const std::string pub = slurp(dir / "id.pub");
  EXPECT_NE(sh.find("\nPUBKEY='" + pub.substr(0, pub.size() - 1) + "'\n"), std::string::npos);
  EXPECT_NE(sh.find("\"$ADMIN_HOME/.ssh/authorized_keys\""), std::string::npos);
  EXPECT_NE(sh.find("\nADMIN='voxcap-admin'\n"), std::string::npos);
  EXPECT_NE(sh.find("NOPASSWD:ALL"), std::string::npos);  // voxcap deploy runs sudo -n
  EXPECT_NE(sh.find("systemctl enable ssh\n"), std::string::npos);
  // The key: 0600 for the service user, off the FAT partition.
  EXPECT_NE(sh.find("install -m 0600 -o \"$SVC\" \"$BOOT/voxcap/rig.key\" /etc/voxcap/rig.key"),
            std::string::npos);
  EXPECT_NE(sh.find("shred -u \"$BOOT/voxcap/rig.key\""), std::string::npos);
  // The package on the next boot, with the network up.
  const std::string firstboot = heredoc(sh, "/usr/local/sbin/voxcap-firstboot");
  EXPECT_NE(firstboot.find("apt-get install -y \"$BOOT/voxcap/voxcap-edge.deb\""), std::string::npos)
      << firstboot;
  EXPECT_NE(firstboot.find("systemctl enable --now voxcap-edge.service"), std::string::npos);
  EXPECT_NE(heredoc(sh, "/etc/systemd/system/voxcap-firstboot.service").find("After=network-online.target"),
            std::string::npos);
  EXPECT_NE(sh.find("systemctl enable voxcap-firstboot.service"), std::string::npos);
  {
    const std::filesystem::path f = dir / "voxcap-firstboot";
    std::ofstream(f) << firstboot;
    EXPECT_EQ(bash_syntax(f), 0);
  }
  // edge.toml, read by the edge's own parser.
  const std::string edge_toml = heredoc(sh, "/etc/voxcap/edge.toml");
  ASSERT_FALSE(edge_toml.empty());
  edge::EdgeSettings s;
  ASSERT_NO_THROW(edge::parse_edge_toml(edge_toml, "edge.toml", s));
  ASSERT_NO_THROW(s.validate());
  EXPECT_EQ(s.node_id, 2);
  EXPECT_EQ(s.key, "rig.key");
  EXPECT_EQ(s.host, "192.168.50.1");
  EXPECT_NE(heredoc(sh, "/etc/modprobe.d/voxcap-imx296.conf").find("options imx296 trigger_mode=1"),
            std::string::npos);
  EXPECT_NE(sh.find("include voxcap-camera.txt"), std::string::npos);
  // eth0's address (NetworkManager keyfile).
  const std::string nm = heredoc(sh, "/etc/NetworkManager/system-connections/voxcap-eth0.nmconnection");
  EXPECT_NE(nm.find("\naddress1=192.168.50.12/24,192.168.50.1\n"), std::string::npos) << nm;
  // Runs once: removes itself and its cmdline.txt words.
  EXPECT_NE(sh.find("rm -f \"$BOOT/firstrun.sh\""), std::string::npos);
  EXPECT_NE(sh.find("sed -i 's| systemd.run.*||g' \"$BOOT/cmdline.txt\""), std::string::npos);
  EXPECT_EQ(slurp(out / "cmdline-firstrun.txt"),
            " systemd.run=/boot/firmware/firstrun.sh systemd.run_success_action=reboot "
            "systemd.unit=kernel-command-line.target\n");
  // The card's files the script reads.
  EXPECT_TRUE(std::filesystem::exists(out / "voxcap" / "rig.key"));
  EXPECT_TRUE(std::filesystem::exists(out / "voxcap" / "voxcap-edge.deb"));
  EXPECT_TRUE(std::filesystem::exists(out / "voxcap-camera.txt"));
}

TEST_F(FlashTest, QuotesWhatTheRigFileSays) {
  // A login user with a quote and a space cannot break out of the script's words.
  std::string text = slurp(dir / "pi5-reference.toml");
  const size_t at = text.find("[deploy]\n");
  ASSERT_NE(at, std::string::npos);
  text.insert(at + 9, "admin_user = \"o'neil $(reboot)\"\n");
  std::ofstream(dir / "pi5-reference.toml") << text;
  Inventory inv;
  try {
    inv = load_inventory(dir / "pi5-reference.toml");
  } catch (const InventoryError&) {
    GTEST_SKIP() << "the inventory refuses such a user name itself";
  }
  FlashOptions o;
  o.node = "pi-a";
  o.out = out;
  o.ssh_key = dir / "id.pub";
  o.first_boot = FirstBoot::Firstrun;
  write_flash_config(inv, o);
  const std::string sh = slurp(out / "firstrun.sh");
  EXPECT_EQ(bash_syntax(out / "firstrun.sh"), 0);
  EXPECT_NE(sh.find("\nADMIN='o'\\''neil $(reboot)'\n"), std::string::npos);
}

TEST_F(FlashTest, CloudInitOnly) {
  const Inventory inv = load_inventory(dir / "pi5-reference.toml");
  FlashOptions o;
  o.node = "pi-a";
  o.out = out;
  o.ssh_key = dir / "id.pub";
  o.first_boot = FirstBoot::CloudInit;
  EXPECT_EQ(write_flash_config(inv, o).files.size(), 6u);
  EXPECT_TRUE(std::filesystem::exists(out / "user-data"));
  EXPECT_FALSE(std::filesystem::exists(out / "firstrun.sh"));
  FirstBoot f{};
  EXPECT_TRUE(first_boot_from_name("firstrun", &f));
  EXPECT_EQ(f, FirstBoot::Firstrun);
  EXPECT_FALSE(first_boot_from_name("cloudinit", &f));
}

TEST_F(FlashTest, FromARepositoryAndDhcp) {
  std::string text = slurp(dir / "pi5-reference.toml");
  text.replace(text.find("network_prefix = 24"), 19,
               "network_prefix = 24\npackage_repo = \"http://192.168.50.1/voxcap\"");
  text.replace(text.find("address = \"192.168.50.13\""), 25, "address = \"pi-c.lab\"");
  std::ofstream(dir / "pi5-reference.toml") << text;
  const Inventory inv = load_inventory(dir / "pi5-reference.toml");
  FlashOptions o;
  o.node = "pi-c";
  o.out = out;
  o.ssh_key = dir / "id.pub";
  write_flash_config(inv, o);
  const YAML::Node u = YAML::LoadFile((out / "user-data").string());
  EXPECT_EQ(u["packages"][0].as<std::string>(), "voxcap-edge");
  EXPECT_EQ(u["apt"]["sources"]["voxcap.list"]["source"].as<std::string>(),
            "deb [trusted=yes] http://192.168.50.1/voxcap ./");
  EXPECT_FALSE(std::filesystem::exists(out / "voxcap" / "voxcap-edge.deb"));
  const YAML::Node n = YAML::LoadFile((out / "network-config").string());
  EXPECT_TRUE(n["network"]["ethernets"]["eth0"]["dhcp4"].as<bool>());
  // firstrun.sh: the repository's apt line, no keyfile (DHCP is NetworkManager's default).
  const std::string sh = slurp(out / "firstrun.sh");
  EXPECT_EQ(bash_syntax(out / "firstrun.sh"), 0);
  EXPECT_EQ(heredoc(sh, "/etc/apt/sources.list.d/voxcap.list"),
            "deb [trusted=yes] http://192.168.50.1/voxcap ./\n");
  EXPECT_NE(heredoc(sh, "/usr/local/sbin/voxcap-firstboot").find("apt-get install -y voxcap-edge\n"),
            std::string::npos);
  EXPECT_EQ(sh.find("nmconnection"), std::string::npos);
}

TEST_F(FlashTest, RefusesWhatItCannotDo) {
  const Inventory inv = load_inventory(dir / "pi5-reference.toml");
  FlashOptions o;
  o.node = "pi-z";
  o.out = out;
  o.ssh_key = dir / "id.pub";
  EXPECT_THROW(write_flash_config(inv, o), InventoryError);
  o.node = "pi-a";
  o.ssh_key = dir / "pi5-reference.yaml";  // not a public key
  EXPECT_THROW(write_flash_config(inv, o), InventoryError);
}

}  // namespace
}  // namespace vc::deploy
