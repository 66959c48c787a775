// Reading the hardware-in-the-loop rig from the environment (VOXCAP_HIL_*). A test whose variables
// are not set skips with a message naming them.
#pragma once

#include <cstdlib>
#include <string>

namespace vc::hil {

inline std::string env(const char* name, const char* fallback = "") {
  const char* v = std::getenv(name);
  return v && *v ? v : fallback;
}

inline long env_long(const char* name, long fallback) {
  std::string v = env(name);
  return v.empty() ? fallback : std::strtol(v.c_str(), nullptr, 10);
}

}  // namespace vc::hil
