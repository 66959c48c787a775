// libFuzzer target for the calibration reader (a rig.yaml is user input): parse_calibration must
// either return a calibration that valid() accepts or throw std::runtime_error with one line, never
// crash, hang, overflow the stack in OpenCV's YAML parser or read out of bounds.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "voxcap/rig/calibration.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const vc::rig::Calibration c = vc::rig::parse_calibration(text, "fuzz.yaml");
    std::string why;
    if (!c.valid(&why)) __builtin_trap();
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).find('\n') != std::string::npos) __builtin_trap();
  }
  return 0;
}
