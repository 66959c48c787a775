// The cloud-init seed of one board. YAML written by hand: every value that comes from the rig file is
// quoted as a YAML double-quoted scalar (yaml_quote), and the test reads the files back with yaml-cpp.
#include "voxcap/deploy/flash.hpp"

#include <sys/stat.h>

#include <fmt/core.h>

#include <fstream>
#include <regex>
#include <sstream>

#include "voxcap/auth.h"

namespace vc::deploy {
namespace {

// The boot partition as Raspberry Pi OS mounts it (bookworm and later).
constexpr const char* kBoot = "/boot/firmware";

std::string yaml_quote(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\')
      o += std::string("\\") + c;
    else if (c == '\n')
      o += "\\n";
    else if (static_cast<unsigned char>(c) < 0x20)
      o += fmt::format("\\x{:02x}", static_cast<unsigned char>(c));
    else
      o += c;
  }
  return o + "\"";
}

std::string indent(const std::string& text, const std::string& pad) {
  std::string o;
  std::istringstream is(text);
  for (std::string line; std::getline(is, line);) o += (line.empty() ? "" : pad) + line + "\n";
  return o;
}

void write(const std::filesystem::path& p, const std::string& text, std::filesystem::perms mode) {
  std::filesystem::create_directories(p.parent_path());
  {
    std::ofstream f(p, std::ios::binary | std::ios::trunc);
    if (!f) throw InventoryError(fmt::format("{}: cannot write", p.string()));
    f << text;
    if (!f.flush()) throw InventoryError(fmt::format("{}: cannot write", p.string()));
  }
  std::filesystem::permissions(p, mode);
}

std::string read_small(const std::filesystem::path& p, const std::string& what) {
  std::ifstream f(p);
  if (!f) throw InventoryError(fmt::format("{}: cannot read {}", p.string(), what));
  std::string line;
  std::getline(f, line);
  return line;
}

bool is_ipv4(const std::string& s) {
  static const std::regex re(R"(^(\d{1,3})\.(\d{1,3})\.(\d{1,3})\.(\d{1,3})$)");
  std::smatch m;
  if (!std::regex_match(s, m, re)) return false;
  for (int i = 1; i <= 4; ++i)
    if (std::stoi(m[i].str()) > 255) return false;
  return true;
}

}  // namespace

bool FlashOptions::valid(std::string* why) const {
  const char* bad = node.empty() ? "--node: missing" : out.empty() ? "--out: missing" : nullptr;
  if (bad && why) *why = bad;
  return bad == nullptr;
}

std::string camera_config_txt() {
  return "# voxcap: two Raspberry Pi Global Shutter cameras (Sony IMX296) on a Raspberry Pi 5, "
         "hardware-triggered\n"
         "# through their XTR pads (hw/rigs/README.md, \"The reference rig\"). Included from config.txt.\n"
         "camera_auto_detect=0\n"
         "dtoverlay=imx296,cam0\n"
         "dtoverlay=imx296,cam1\n";
}

FlashResult write_flash_config(const Inventory& inv, const FlashOptions& opt) {
  std::string why;
  if (!opt.valid(&why)) throw InventoryError(why);
  const Board* b = inv.board(opt.node);
  if (!b) {
    std::string ids;
    for (const Board& x : inv.boards) ids += (ids.empty() ? "" : ", ") + x.id;
    throw InventoryError(
        fmt::format("--node {}: no such node in {} (nodes: {})", opt.node, inv.rig.source.string(), ids));
  }
  const std::filesystem::path key_file = opt.ssh_key.empty() ? inv.flash.authorized_key : opt.ssh_key;
  if (key_file.empty())
    throw InventoryError(
        "no ssh public key for the login user: give --ssh-key FILE.pub or [deploy] authorized_key");
  const std::string pubkey = read_small(key_file, "the ssh public key");
  if (pubkey.rfind("ssh-", 0) != 0 && pubkey.rfind("ecdsa-", 0) != 0 && pubkey.rfind("sk-", 0) != 0)
    throw InventoryError(fmt::format(
        "{}: not an OpenSSH public key (one line, \"ssh-ed25519 AAAA... comment\")", key_file.string()));
  const std::filesystem::path package = opt.package.empty() ? inv.package : opt.package;
  const bool from_repo = opt.package.empty() && !inv.flash.package_repo.empty();
  if (!from_repo && package.empty())
    throw InventoryError(
        "no voxcap-edge package: give --package FILE.deb, [deploy] package or [deploy] package_repo");
  const std::string admin = inv.flash.admin_user;
  const std::string svc_user = b->settings.service_user;
  FlashResult res;
  const auto rw = std::filesystem::perms::owner_read | std::filesystem::perms::owner_write;
  const auto pub = rw | std::filesystem::perms::group_read | std::filesystem::perms::others_read;
  std::filesystem::create_directories(opt.out);

  // The rig key: a file of its own on the card, moved into /etc/voxcap by the first boot and then
  // removed from the (FAT, world-readable) boot partition.
  if (!inv.rig.key_path.empty()) {
    uint8_t k[VC_AUTH_KEY_SIZE];
    char w[512];
    if (vc_key_load(inv.rig.key_path.c_str(), k, w, sizeof w) < 0) throw InventoryError(w);
    std::string hex;
    for (uint8_t c : k) hex += fmt::format("{:02x}", c);
    write(opt.out / "voxcap" / "rig.key", hex + "\n", rw);
    res.files.push_back("voxcap/rig.key");
  }
  if (!from_repo) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(package, ec))
      throw InventoryError(fmt::format("{}: no such package file", package.string()));
    std::filesystem::copy_file(package, opt.out / "voxcap" / "voxcap-edge.deb",
                               std::filesystem::copy_options::overwrite_existing);
    res.files.push_back("voxcap/voxcap-edge.deb");
  }
  write(opt.out / "voxcap-camera.txt", camera_config_txt(), pub);
  res.files.push_back("voxcap-camera.txt");

  // meta-data: the instance id changes with every flash-config, so a re-flashed card runs again.
  uint8_t r[6];
  vc_auth_init();
  vc_auth_random(r, sizeof r);
  std::string nonce;
  for (uint8_t c : r) nonce += fmt::format("{:02x}", c);
  write(opt.out / "meta-data",
        fmt::format("instance-id: {}\nlocal-hostname: {}\n", yaml_quote("voxcap-" + b->id + "-" + nonce),
                    yaml_quote(b->id)),
        pub);
  res.files.push_back("meta-data");

  // network-config (v2): the node's address on eth0 when the rig names one, else DHCP.
  std::string net = "network:\n  version: 2\n  ethernets:\n    eth0:\n";
  if (is_ipv4(b->address)) {
    net += fmt::format("      dhcp4: false\n      addresses: [{}]\n",
                       yaml_quote(fmt::format("{}/{}", b->address, inv.flash.network_prefix)));
    if (!inv.flash.gateway.empty())
      net += fmt::format("      routes:\n        - to: default\n          via: {}\n",
                         yaml_quote(inv.flash.gateway));
    if (!inv.flash.dns.empty()) {
      net += "      nameservers:\n        addresses: [";
      for (size_t i = 0; i < inv.flash.dns.size(); ++i) net += (i ? ", " : "") + yaml_quote(inv.flash.dns[i]);
      net += "]\n";
    }
  } else {
    net += "      dhcp4: true\n";
  }
  write(opt.out / "network-config", net, pub);
  res.files.push_back("network-config");

  // user-data (#cloud-config).
  std::string u = "#cloud-config\n";
  u += fmt::format(
      "# voxcap edge node {} of rig {}: written by voxcap deploy flash-config (host/deploy/README.md).\n",
      b->id, inv.rig.name);
  u += fmt::format("hostname: {}\nmanage_etc_hosts: true\n", yaml_quote(b->id));
  if (!inv.flash.timezone.empty()) u += fmt::format("timezone: {}\n", yaml_quote(inv.flash.timezone));
  u += "ssh_pwauth: false\n";
  u += "users:\n";
  u += fmt::format(
      "  - name: {}\n    groups: [sudo, video, gpio, plugdev]\n    shell: /bin/bash\n    lock_passwd: true\n"
      "    sudo: \"ALL=(ALL) NOPASSWD:ALL\"\n    ssh_authorized_keys:\n      - {}\n",
      yaml_quote(admin), yaml_quote(pubkey));
  u += fmt::format(
      "  - name: {}\n    system: true\n    groups: [video, gpio, plugdev]\n    homedir: /var/lib/voxcap\n"
      "    shell: /usr/sbin/nologin\n    lock_passwd: true\n",
      yaml_quote(svc_user));
  if (from_repo) {
    u += "apt:\n  sources:\n    voxcap.list:\n";
    u += fmt::format("      source: {}\n", yaml_quote("deb [trusted=yes] " + inv.flash.package_repo + " ./"));
    u += "package_update: true\npackages:\n  - voxcap-edge\n";
  }
  u += "write_files:\n";
  u += "  - path: /etc/voxcap/edge.toml\n    permissions: \"0644\"\n    owner: \"root:root\"\n    content: "
       "|\n" +
       indent(b->edge_toml, "      ");
  u += "  - path: /etc/modprobe.d/voxcap-imx296.conf\n    permissions: \"0644\"\n    content: |\n"
       "      # The Global Shutter camera waits for its XTR pulse (Raspberry Pi's documentation: "
       "trigger_mode 1)\n"
       "      options imx296 trigger_mode=1\n";
  u += "runcmd:\n";
  auto cmd = [&](const std::string& c) { u += "  - " + yaml_quote(c) + "\n"; };
  cmd("systemctl enable --now ssh");
  cmd(
      fmt::format("grep -qx 'include voxcap-camera.txt' {0}/config.txt || printf '\\ninclude "
                  "voxcap-camera.txt\\n' >> {0}/config.txt",
                  kBoot));
  cmd("mkdir -p /etc/voxcap /var/lib/voxcap/deploy");
  if (!from_repo) {
    cmd(fmt::format("apt-get install -y {}/voxcap/voxcap-edge.deb", kBoot));
    cmd(fmt::format("cp {}/voxcap/voxcap-edge.deb /var/lib/voxcap/deploy/current.deb", kBoot));
  }
  if (!inv.rig.key_path.empty()) {
    cmd(fmt::format("install -m 0600 -o {} {}/voxcap/rig.key /etc/voxcap/rig.key", svc_user, kBoot));
    cmd(fmt::format("shred -u {}/voxcap/rig.key || rm -f {}/voxcap/rig.key", kBoot, kBoot));
  }
  cmd(fmt::format("chown -R {} /var/lib/voxcap", svc_user));
  cmd("systemctl enable voxcap-edge.service");
  u += "power_state:\n  mode: reboot\n  message: \"voxcap: rebooting so config.txt's camera overlays and the "
       "trigger mode apply\"\n"
       "  condition: true\n";
  write(opt.out / "user-data", u, pub);
  res.files.push_back("user-data");
  return res;
}

}  // namespace vc::deploy
