// `voxcap deploy flash-config`: the files a freshly flashed Raspberry Pi OS image reads from its boot
// partition on first boot, so the board comes up as one rig node without a keyboard: hostname, login
// user with an ssh key, the voxcap-edge package, its edge.toml and the rig key (0600, the service
// user's), the cameras' overlay and external-trigger mode. Two mechanisms, for two generations of
// images: cloud-init's NoCloud seed (user-data, meta-data, network-config; images from October 2025,
// trixie) and Raspberry Pi Imager's firstrun.sh, run once through systemd.run= on cmdline.txt
// (bookworm). Which to use: host/deploy/README.md "Flashing".
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "voxcap/deploy/inventory.hpp"

namespace vc::deploy {

// Which first-boot files to write: both by default (each is inert on the other generation's image).
enum class FirstBoot { Both, CloudInit, Firstrun };
// "both", "cloud-init", "firstrun"; false for any other name.
bool first_boot_from_name(const std::string& name, FirstBoot* out);

struct FlashOptions {
  std::string node;               // the rig node this card becomes
  std::filesystem::path out;      // folder to write (its contents go on the boot partition)
  std::filesystem::path ssh_key;  // public key for the login user ("" = [deploy] authorized_key)
  std::filesystem::path
      package;  // a voxcap-edge .deb to copy onto the card ("" = [deploy] package_repo, or package)
  FirstBoot first_boot = FirstBoot::Both;

  bool valid(std::string* why) const;
};

// Paths written, relative to out (for the message and the test).
struct FlashResult {
  std::vector<std::string> files;
};

// Writes the files; throws InventoryError for bad input (no such node, no ssh key, neither a package
// nor a repository).
FlashResult write_flash_config(const Inventory& inv, const FlashOptions& opt);

// The lines flash-config puts in the boot partition's voxcap-camera.txt (config.txt includes it):
// camera_auto_detect=0 and one imx296 overlay per CSI port.
std::string camera_config_txt();

// What firstrun.sh needs appended to the card's cmdline.txt (its one line), as Raspberry Pi Imager
// appends it: a leading space, then systemd.run=/boot/firmware/firstrun.sh and the reboot after it.
std::string firstrun_cmdline_args();

}  // namespace vc::deploy
