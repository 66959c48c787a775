// voxcap deploy [--inventory rig.toml] [--package FILE.deb] [--rotate-key] [--dry-run] [--node ID]...
// voxcap deploy flash-config --node NAME --inventory rig.toml --out DIR [--ssh-key FILE.pub] [--package
// FILE.deb] The boards of a rig over ssh, and the first-boot files of a fresh card (host/deploy/README.md).
#include <fmt/core.h>

#include <cstdio>
#include <mutex>

#include "commands.hpp"
#include "voxcap/config/rig_config.hpp"
#include "voxcap/deploy/deploy.hpp"
#include "voxcap/deploy/flash.hpp"

namespace vc::cli {
namespace {

deploy::Inventory load(const std::string& path) {
  try {
    return deploy::load_inventory(path);
  } catch (const config::ConfigError& e) {
    throw UsageError(e.what());
  } catch (const deploy::InventoryError& e) {
    throw UsageError(e.what());
  }
}

}  // namespace

void add_deploy_commands(CLI::App& app) {
  CLI::App* dep = app.add_subcommand(
      "deploy",
      "install or upgrade voxcap-edge on every board of the rig over ssh (OpenSSH, BatchMode; [deploy] and "
      "[[nodes]] ssh in rig.toml): write each board's /etc/voxcap/edge.toml from the rig file and the rig "
      "key "
      "(/etc/voxcap/rig.key, 0600, the service user's), restart voxcap-edge.service, check that it is "
      "active, "
      "runs the package's version (voxcap-edge --version) and proves the rig key (voxcap-edge --prove-key), "
      "and, when no voxcap-host holds the rig's port, that it rejoined the rig: its keyed HELLO on that "
      "port with the package's version, within [deploy] hello_timeout_s (20); "
      "roll back a board that fails (previous package, edge.toml and key). Progress per board, a summary, "
      "exit 1 when any board failed. host/deploy/README.md");
  auto inventory = std::make_shared<std::string>();
  auto package = std::make_shared<std::string>();
  auto nodes = std::make_shared<std::vector<std::string>>();
  auto rotate = std::make_shared<bool>(false);
  auto dry = std::make_shared<bool>(false);
  auto accept_new = std::make_shared<bool>(false);
  dep->add_option("--inventory", *inventory,
                  "the rig.toml with the boards ([deploy], [[nodes]] ssh); default: "
                  "$VOXCAP_RIG, ./rig.toml");
  dep->add_option("--package", *package,
                  "the voxcap-edge .deb to install (default: [deploy] package; none: "
                  "configuration and key only)");
  dep->add_flag(
      "--rotate-key", *rotate,
      "make a new rig key (<key>.next), install it on every board beside the old one (edge.toml next_key: "
      "the board takes either key, so it keeps capturing with the running host), check each proves it, then "
      "switch the host's key file (the old one kept as <key>.old; restart voxcap-host, then a plain deploy "
      "drops the old key from the boards); boards left with the old key are named and the host keeps its "
      "key");
  dep->add_flag("--dry-run", *dry,
                "connect, report what each board runs and what would change; change nothing");
  dep->add_option("--node", *nodes, "only this board (repeat for more)");
  dep->add_flag(
      "--accept-new-host-keys", *accept_new,
      "StrictHostKeyChecking=accept-new: record the host key of a board seen for the first time (a changed "
      "key is still refused)");

  CLI::App* flash = dep->add_subcommand(
      "flash-config",
      "write what a freshly flashed Raspberry Pi OS card needs on its boot partition to come up as NODE on "
      "first "
      "boot without a keyboard (cloud-init: user-data, meta-data, network-config; voxcap-camera.txt; the "
      "package "
      "and the rig key under voxcap/). Copy DIR's contents onto the card's boot partition");
  auto f_node = std::make_shared<std::string>();
  auto f_inv = std::make_shared<std::string>();
  auto f_out = std::make_shared<std::string>();
  auto f_key = std::make_shared<std::string>();
  auto f_pkg = std::make_shared<std::string>();
  auto f_boot = std::make_shared<std::string>("both");
  flash->add_option("--node", *f_node, "the rig node this card becomes (nodes[].id)")->required();
  flash->add_option("--inventory", *f_inv, "the rig.toml")->required();
  flash->add_option("--out", *f_out, "the folder to write")->required();
  flash->add_option("--ssh-key", *f_key,
                    "the login user's ssh public key (default: [deploy] authorized_key)");
  flash->add_option("--package", *f_pkg,
                    "a voxcap-edge .deb to put on the card (default: [deploy] package_repo, "
                    "else [deploy] package)");
  flash->add_option("--first-boot", *f_boot,
                    "which first-boot files: cloud-init (user-data, meta-data, network-config: images from "
                    "October 2025, trixie), firstrun (firstrun.sh and cmdline-firstrun.txt, whose words go "
                    "at the end of the card's cmdline.txt: bookworm images) or both (default)");
  flash->callback([=] {
    const deploy::Inventory inv = load(*f_inv);
    deploy::FlashOptions o;
    o.node = *f_node;
    o.out = *f_out;
    o.ssh_key = *f_key;
    o.package = *f_pkg;
    if (!deploy::first_boot_from_name(*f_boot, &o.first_boot))
      throw UsageError(fmt::format("--first-boot: \"{}\" is none of cloud-init, firstrun, both", *f_boot));
    deploy::FlashResult r;
    try {
      r = deploy::write_flash_config(inv, o);
    } catch (const deploy::InventoryError& e) {
      throw UsageError(e.what());
    }
    fmt::print("wrote the first-boot files of node {} to {}:\n", o.node, o.out.string());
    for (const auto& f : r.files) fmt::print("  {}\n", f);
    fmt::print("copy them onto the card's boot partition (bootfs) after flashing; host/deploy/README.md\n");
    if (o.first_boot != deploy::FirstBoot::CloudInit)
      fmt::print(
          "a bookworm image: append cmdline-firstrun.txt to the end of the card's cmdline.txt (one line):\n"
          "  sed -i \"1s|\\$|$(cat {}/cmdline-firstrun.txt)|\" /media/$USER/bootfs/cmdline.txt\n",
          o.out.string());
  });

  dep->callback([=] {
    if (dep->got_subcommand("flash-config")) return;
    const std::string path = inventory->empty() ? config::default_rig_config_path().string() : *inventory;
    deploy::Inventory inv = load(path);
    if (*accept_new)
      for (auto& b : inv.boards) b.settings.host_key_checking = "accept-new";
    deploy::DeployOptions o;
    o.package = *package;
    o.rotate_key = *rotate;
    o.dry_run = *dry;
    o.nodes = *nodes;
    std::mutex mu;
    auto progress = [&mu](const std::string& board, const std::string& line) {
      std::lock_guard<std::mutex> lock(mu);
      fmt::print("{}{}\n", board.empty() ? "" : "[" + board + "] ", line);
      std::fflush(stdout);
    };
    deploy::SshRemote ssh;
    deploy::DeployReport r;
    try {
      r = deploy::run_deploy(inv, o, ssh, progress);
    } catch (const deploy::InventoryError& e) {
      throw UsageError(e.what());
    }
    fmt::print("\n{}", deploy::format_summary(r, o.rotate_key));
    if (!r.ok()) {
      std::string names;
      for (const auto& b : r.boards)
        if (!b.ok) names += " " + b.id;
      for (const auto& id : r.left_with_old_key)
        if (names.find(" " + id) == std::string::npos) names += " " + id;
      throw std::runtime_error("deploy failed on:" + names);
    }
  });
}

}  // namespace vc::cli
