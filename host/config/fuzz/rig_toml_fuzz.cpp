// libFuzzer target for the rig.toml reader (a rig.toml is user input): parse_rig_config (without the
// calibration file: the grid comes from [grid]) must either return a configuration that valid()
// accepts or throw ConfigError with one line, never crash, hang or read out of bounds.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "voxcap/config/rig_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  vc::config::LoadOptions options;
  options.load_calibration = false;
  try {
    const vc::config::RigConfig c = vc::config::parse_rig_config(text, "/fuzz/rig.toml", options);
    std::string why;
    if (!c.valid(&why)) __builtin_trap();
  } catch (const vc::config::ConfigError& e) {
    if (std::string(e.what()).find('\n') != std::string::npos) __builtin_trap();
  }
  return 0;
}
