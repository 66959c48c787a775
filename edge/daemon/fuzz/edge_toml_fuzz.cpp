// libFuzzer target for the edge's configuration reader (an edge.toml is user input): parse_edge_toml
// must either fill settings that validate() accepts or refuses, or throw ConfigError with one line,
// never crash, hang or read out of bounds; and the accepted settings must convert to the daemon's
// options (to_options) without overflow.
#include <cstddef>
#include <cstdint>
#include <string>

#include "config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  vc::edge::EdgeSettings s;
  try {
    vc::edge::parse_edge_toml(text, "fuzz.toml", s);
    s.validate();
  } catch (const vc::edge::ConfigError& e) {
    if (std::string(e.what()).find('\n') != std::string::npos) __builtin_trap();
    return 0;
  }
  const vc_edged_options o = vc::edge::to_options(s);
  if (o.node_id != s.node_id) __builtin_trap();
  return 0;
}
