// The first-boot files of one board: cloud-init's seed and Raspberry Pi Imager's firstrun.sh. YAML and
// shell written by hand: every value that comes from the rig file is quoted, as a YAML double-quoted
// scalar (yaml_quote) or a shell single-quoted word (sh_quote); edge.toml goes into the script as a
// quoted here-document whose end marker it must not contain. The test reads the YAML back with yaml-cpp
// and the script with `bash -n` and the edge's own reader.
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

// A shell word that is exactly s: single quotes, each ' as '\''.
std::string sh_quote(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

// A value that goes on one line of a file the script writes (no newline can start a key of its own).
void one_line(const std::string& s, const std::string& what) {
  for (char c : s)
    if (static_cast<unsigned char>(c) < 0x20)
      throw InventoryError(fmt::format("{}: a control character in \"{}\"", what, s));
}

bool is_ipv4(const std::string& s) {
  static const std::regex re(R"(^(\d{1,3})\.(\d{1,3})\.(\d{1,3})\.(\d{1,3})$)");
  std::smatch m;
  if (!std::regex_match(s, m, re)) return false;
  for (int i = 1; i <= 4; ++i)
    if (std::stoi(m[i].str()) > 255) return false;
  return true;
}

constexpr auto kOwnerOnly = std::filesystem::perms::owner_read | std::filesystem::perms::owner_write;
constexpr auto kPublic =
    kOwnerOnly | std::filesystem::perms::group_read | std::filesystem::perms::others_read;

// What both first-boot mechanisms say about one board.
struct Seed {
  const Inventory& inv;
  const Board& board;
  const std::filesystem::path& out;
  const std::string& pubkey;    // the login user's OpenSSH public key, one line
  const std::string& admin;     // the login user
  const std::string& svc_user;  // the service's system user
  bool from_repo;               // the package from [deploy] package_repo, not voxcap/voxcap-edge.deb
};

void write_cloud_init(const Seed& s, FlashResult& res);
void write_firstrun(const Seed& s, FlashResult& res);

}  // namespace

bool first_boot_from_name(const std::string& name, FirstBoot* out) {
  if (name == "both")
    *out = FirstBoot::Both;
  else if (name == "cloud-init")
    *out = FirstBoot::CloudInit;
  else if (name == "firstrun")
    *out = FirstBoot::Firstrun;
  else
    return false;
  return true;
}

std::string firstrun_cmdline_args() {
  return fmt::format(
      " systemd.run={}/firstrun.sh systemd.run_success_action=reboot "
      "systemd.unit=kernel-command-line.target",
      kBoot);
}

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
  const auto rw = kOwnerOnly;
  const auto pub = kPublic;
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
  const Seed seed{inv, *b, opt.out, pubkey, admin, svc_user, from_repo};
  if (opt.first_boot != FirstBoot::Firstrun) write_cloud_init(seed, res);
  if (opt.first_boot != FirstBoot::CloudInit) write_firstrun(seed, res);
  return res;
}

namespace {

void write_cloud_init(const Seed& s, FlashResult& res) {
  const Inventory& inv = s.inv;
  const Board* b = &s.board;
  const std::string& admin = s.admin;
  const std::string& svc_user = s.svc_user;
  const std::string& pubkey = s.pubkey;
  const bool from_repo = s.from_repo;
  const std::filesystem::path& out = s.out;
  const auto pub = kPublic;

  // meta-data: the instance id changes with every flash-config, so a re-flashed card runs again.
  uint8_t r[6];
  vc_auth_init();
  vc_auth_random(r, sizeof r);
  std::string nonce;
  for (uint8_t c : r) nonce += fmt::format("{:02x}", c);
  write(out / "meta-data",
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
  write(out / "network-config", net, pub);
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
  write(out / "user-data", u, pub);
  res.files.push_back("user-data");
}

// firstrun.sh: what Raspberry Pi Imager's customisation does on a bookworm image, run once by systemd
// (systemd.run= on cmdline.txt) before the network is up, then removed with its cmdline.txt arguments;
// systemd reboots after it. The package needs the network (its dependencies), so the script leaves a
// one-shot unit, voxcap-firstboot.service, that installs it on the next boot once the network is
// online and then disables itself.
void write_firstrun(const Seed& s, FlashResult& res) {
  const Board& b = s.board;
  const FlashSettings& fl = s.inv.flash;
  const std::string boot = kBoot;
  // Values that land on a line of a file the script writes: one line each, and the addresses IPv4.
  one_line(s.pubkey, "the ssh public key");
  one_line(fl.timezone, "[deploy] timezone");
  one_line(fl.package_repo, "[deploy] package_repo");
  const bool fixed = is_ipv4(b.address);
  if (fixed && !fl.gateway.empty() && !is_ipv4(fl.gateway))
    throw InventoryError(fmt::format("[deploy] gateway: \"{}\" is not an IPv4 address", fl.gateway));
  for (const std::string& d : fl.dns)
    if (fixed && !is_ipv4(d))
      throw InventoryError(fmt::format("[deploy] dns: \"{}\" is not an IPv4 address", d));
  // A file's text as a here-document whose end marker no line of it is.
  auto heredoc = [](const std::string& path, const std::string& text, const char* mode) {
    const std::string end = "VOXCAP_END_OF_FILE";
    std::istringstream is(text);
    for (std::string line; std::getline(is, line);)
      if (line == end) throw InventoryError(fmt::format("{}: a line reads {}", path, end));
    std::string body = text;
    if (!body.empty() && body.back() != '\n') body += '\n';
    const std::string dir = std::filesystem::path(path).parent_path().string();
    return fmt::format("mkdir -p {4}\ncat >{0} <<'{1}'\n{2}{1}\nchmod {3} {0}\n", path, end, body, mode, dir);
  };

  std::string sh = "#!/bin/bash\n";
  sh += fmt::format(
      "# voxcap edge node {} of rig {}: written by voxcap deploy flash-config (host/deploy/README.md).\n"
      "# A bookworm image runs it once from cmdline.txt ({}), before the\n"
      "# network is up; it removes itself and those arguments, and systemd reboots. The package is "
      "installed\n"
      "# on the boot after, with the network up (voxcap-firstboot.service).\n",
      b.id, s.inv.rig.name, "systemd.run=" + boot + "/firstrun.sh");
  sh += "set +e\n";
  sh += fmt::format("BOOT={}\nNODE={}\nADMIN={}\nSVC={}\nPUBKEY={}\n", boot, sh_quote(b.id),
                    sh_quote(s.admin), sh_quote(s.svc_user), sh_quote(s.pubkey));
  sh += "exec >>/var/log/voxcap-firstrun.log 2>&1\n";
  sh += "echo \"voxcap firstrun: $(date)\"\n\n";
  sh +=
      "# The hostname, as Imager sets it.\n"
      "CURRENT=$(tr -d ' \\t\\n\\r' </etc/hostname)\n"
      "if [ -x /usr/lib/raspberrypi-sys-mods/imager_custom ]; then\n"
      "  /usr/lib/raspberrypi-sys-mods/imager_custom set_hostname \"$NODE\"\n"
      "else\n"
      "  echo \"$NODE\" >/etc/hostname\n"
      "  sed -i \"s/127.0.1.1.*$CURRENT/127.0.1.1\\t$NODE/g\" /etc/hosts\n"
      "fi\n\n";
  sh +=
      "# The login user (the image's first user renamed, as Imager does), ssh key only, password-less sudo\n"
      "# (what voxcap deploy runs); the first-boot user wizard is not needed.\n"
      "FIRSTUSER=$(getent passwd 1000 | cut -d: -f1)\n"
      "if [ -n \"$FIRSTUSER\" ] && [ \"$FIRSTUSER\" != \"$ADMIN\" ] && [ -x /usr/lib/userconf-pi/userconf ]; "
      "then\n"
      "  /usr/lib/userconf-pi/userconf \"$ADMIN\" '!'\n"
      "fi\n"
      "id -u \"$ADMIN\" >/dev/null 2>&1 || useradd -m -s /bin/bash \"$ADMIN\"\n"
      "for g in sudo video gpio plugdev; do getent group \"$g\" >/dev/null && usermod -aG \"$g\" \"$ADMIN\"; "
      "done\n"
      "usermod -p '!' \"$ADMIN\"\n"
      "systemctl disable userconfig.service 2>/dev/null\n"
      "ADMIN_HOME=$(getent passwd \"$ADMIN\" | cut -d: -f6)\n"
      "install -d -m 0700 -o \"$ADMIN\" -g \"$ADMIN\" \"$ADMIN_HOME/.ssh\"\n"
      "printf '%s\\n' \"$PUBKEY\" >\"$ADMIN_HOME/.ssh/authorized_keys\"\n"
      "chown \"$ADMIN:$ADMIN\" \"$ADMIN_HOME/.ssh/authorized_keys\"\n"
      "chmod 0600 \"$ADMIN_HOME/.ssh/authorized_keys\"\n"
      "printf '%s ALL=(ALL) NOPASSWD:ALL\\n' \"$ADMIN\" >/etc/sudoers.d/010_voxcap-admin\n"
      "chmod 0440 /etc/sudoers.d/010_voxcap-admin\n"
      "printf 'PasswordAuthentication no\\n' >/etc/ssh/sshd_config.d/voxcap.conf\n"
      "systemctl enable ssh\n\n";
  sh +=
      "# The service's system user (the package's postinst finds it there).\n"
      "id -u \"$SVC\" >/dev/null 2>&1 || useradd --system --home-dir /var/lib/voxcap --shell "
      "/usr/sbin/nologin "
      "\"$SVC\"\n"
      "for g in video gpio plugdev; do getent group \"$g\" >/dev/null && usermod -aG \"$g\" \"$SVC\"; done\n"
      "install -d -m 0755 /etc/voxcap /var/lib/voxcap/deploy\n\n";
  if (!fl.timezone.empty())
    sh += fmt::format(
        "TZONE={}\n[ -e \"/usr/share/zoneinfo/$TZONE\" ] && ln -sf \"/usr/share/zoneinfo/$TZONE\" "
        "/etc/localtime && echo \"$TZONE\" >/etc/timezone\n\n",
        sh_quote(fl.timezone));
  if (fixed) {
    std::string nm = fmt::format(
        "[connection]\nid=voxcap-eth0\ntype=ethernet\ninterface-name=eth0\nautoconnect=true\n\n[ipv4]\n"
        "method=manual\naddress1={}/{}{}\n",
        b.address, fl.network_prefix, fl.gateway.empty() ? "" : "," + fl.gateway);
    if (!fl.dns.empty()) {
      nm += "dns=";
      for (const std::string& d : fl.dns) nm += d + ";";
      nm += "\n";
    }
    nm += "\n[ipv6]\nmethod=ignore\n";
    sh += "# eth0's address from the rig file (NetworkManager, bookworm's network stack).\n";
    sh += heredoc("/etc/NetworkManager/system-connections/voxcap-eth0.nmconnection", nm, "0600");
    sh += "\n";
  }
  sh += "# The node's configuration and the cameras' external trigger mode.\n";
  sh += heredoc("/etc/voxcap/edge.toml", b.edge_toml, "0644");
  sh += heredoc("/etc/modprobe.d/voxcap-imx296.conf",
                "# The Global Shutter camera waits for its XTR pulse (Raspberry Pi's documentation: "
                "trigger_mode 1)\noptions imx296 trigger_mode=1\n",
                "0644");
  sh += fmt::format(
      "grep -qx 'include voxcap-camera.txt' {0}/config.txt || printf '\\ninclude voxcap-camera.txt\\n' >> "
      "{0}/config.txt\n",
      boot);
  if (!s.inv.rig.key_path.empty())
    sh +=
        "# The rig key, off the FAT partition.\n"
        "install -m 0600 -o \"$SVC\" \"$BOOT/voxcap/rig.key\" /etc/voxcap/rig.key && "
        "{ shred -u \"$BOOT/voxcap/rig.key\" || rm -f \"$BOOT/voxcap/rig.key\"; }\n";
  sh += "\n# The package on the next boot, with the network up.\n";
  std::string install;
  if (s.from_repo) {
    sh += heredoc("/etc/apt/sources.list.d/voxcap.list", "deb [trusted=yes] " + fl.package_repo + " ./\n",
                  "0644");
    install = "apt-get update\napt-get install -y voxcap-edge\n";
  } else {
    install =
        "apt-get install -y \"$BOOT/voxcap/voxcap-edge.deb\"\n"
        "cp \"$BOOT/voxcap/voxcap-edge.deb\" /var/lib/voxcap/deploy/current.deb\n";
  }
  sh += heredoc("/usr/local/sbin/voxcap-firstboot",
                "#!/bin/bash\n# voxcap: the package, once the network is up (written by firstrun.sh).\n"
                "set -e\nBOOT=" +
                    boot + "\nSVC=" + sh_quote(s.svc_user) + "\n" + install +
                    "chown -R \"$SVC\" /var/lib/voxcap\nsystemctl enable --now voxcap-edge.service\n"
                    "systemctl disable voxcap-firstboot.service\n",
                "0755");
  sh += heredoc("/etc/systemd/system/voxcap-firstboot.service",
                "[Unit]\nDescription=voxcap: install voxcap-edge once the network is up (firstrun.sh)\n"
                "Wants=network-online.target\nAfter=network-online.target\n\n[Service]\nType=oneshot\n"
                "ExecStart=/usr/local/sbin/voxcap-firstboot\n\n[Install]\nWantedBy=multi-user.target\n",
                "0644");
  sh += "systemctl enable voxcap-firstboot.service\n\n";
  sh +=
      "# Done: as Imager's script ends, so this runs once.\n"
      "rm -f \"$BOOT/firstrun.sh\"\n"
      "sed -i 's| systemd.run.*||g' \"$BOOT/cmdline.txt\"\n"
      "exit 0\n";
  write(s.out / "firstrun.sh", sh, kPublic | std::filesystem::perms::owner_exec);
  res.files.push_back("firstrun.sh");
  write(s.out / "cmdline-firstrun.txt", firstrun_cmdline_args() + "\n", kPublic);
  res.files.push_back("cmdline-firstrun.txt");
}

}  // namespace

}  // namespace vc::deploy
