// Where one voxcap program finds another (programs.hpp).
#include "voxcap/base/programs.hpp"

#include <unistd.h>

#include <algorithm>
#include <system_error>

#ifndef VOXCAP_INSTALL_BINDIR
#define VOXCAP_INSTALL_BINDIR "/usr/local/bin"
#endif
#ifndef VOXCAP_INSTALL_LIBEXECDIR
#define VOXCAP_INSTALL_LIBEXECDIR "/usr/local/libexec/voxcap"
#endif

namespace vc {

namespace fs = std::filesystem;

std::vector<fs::path> program_candidates(const std::string& name) {
  std::vector<fs::path> out;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path dir = self.parent_path();
    out.push_back(dir / name);
    out.push_back(dir.parent_path() / "libexec" / "voxcap" / name);  // from <prefix>/bin
    if (dir.filename() == "voxcap" && dir.parent_path().filename() == "libexec")
      out.push_back(dir.parent_path().parent_path() / "bin" / name);  // from <prefix>/libexec/voxcap
  }
  for (const fs::path& p :
       {fs::path(VOXCAP_INSTALL_BINDIR) / name, fs::path(VOXCAP_INSTALL_LIBEXECDIR) / name})
    if (std::find(out.begin(), out.end(), p) == out.end()) out.push_back(p);
  return out;
}

fs::path find_program(const std::string& name) {
  for (const fs::path& p : program_candidates(name)) {
    std::error_code ec;
    if (fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0) return p;
  }
  return {};
}

}  // namespace vc
