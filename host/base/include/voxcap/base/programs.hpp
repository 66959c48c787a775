// Where one voxcap program finds another (voxcap -> voxcap-bench, the emulated rig -> voxcap-edge):
// beside the running program first (a build tree's bin/, or an install's bin/), then the install
// layout relative to it (<bin>/../libexec/voxcap; from <prefix>/libexec/voxcap: <prefix>/bin), so an
// install moved or unpacked elsewhere (dpkg -x) still works, then the install prefix this build was
// configured with (its bin/ and libexec/voxcap/; VOXCAP_INSTALL_BINDIR, VOXCAP_INSTALL_LIBEXECDIR). Packages
// install user commands (voxcap, voxcap-host, voxcap-edge) in bin/ and helpers (voxcap-bench) in
// libexec/voxcap/ (deploy/README.md).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace vc {

// The places searched for program `name`, in order (for error messages).
std::vector<std::filesystem::path> program_candidates(const std::string& name);

// The first candidate that exists and is executable, or an empty path.
std::filesystem::path find_program(const std::string& name);

}  // namespace vc
