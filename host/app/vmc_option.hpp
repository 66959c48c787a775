// `--vmc HOST:PORT` of `voxcap rig` and `voxcap demo`, and the VMC stage added to a pipeline: the live
// pose stream out (host/stream) from the command line or rig.toml's [vmc].
#pragma once

#include <memory>
#include <string>

#include "commands.hpp"
#include "voxcap/config/options.hpp"
#include "voxcap/pipeline/pipeline.hpp"
#include "voxcap/stream/vmc_stage.hpp"

namespace vc::cli {

inline constexpr const char* kVmcHelp =
    "Stream the fitted pose live over the VMC protocol (OSC bundles over UDP, what VSeeFace, Unity's "
    "EVMC4U and Blender's VMC add-ons receive) to HOST:PORT: a numeric IPv4 address or localhost, VMC's "
    "usual port is 39539; another PC's address sends every pose over the network. Rate: rig.toml's [vmc] "
    "rate_hz (default 60, at most the rig's rate). Overrides [vmc] target and enables it";

// `base` with --vmc applied (empty: unchanged). Throws UsageError for a malformed HOST:PORT.
inline config::VmcOptions vmc_options(config::VmcOptions base, const std::string& text) {
  if (text.empty()) return base;
  std::string why;
  if (!config::Endpoint::parse(text, &base.target, &why)) throw UsageError("--vmc: " + why);
  base.enabled = true;
  return base;
}

// The VMC stage on `p` (before start) when the options enable it.
inline void add_vmc_stage(pipeline::Pipeline& p, const config::VmcOptions& o) {
  if (o.enabled) p.tap(std::make_unique<stream::VmcStage>(o), stream::VmcStage::kQueue);
}

}  // namespace vc::cli
