// libFuzzer target for the BVH reader and the humanoid mapping (user files are untrusted bytes):
// parsing must either succeed with a consistent clip or throw std::runtime_error, never crash,
// hang or read out of bounds; a parsed clip's poses and forward kinematics must be computable, and
// mapping it onto the standard joints must either succeed or throw std::runtime_error.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "voxcap/body/bvh.hpp"
#include "voxcap/body/humanoid.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  vc::body::BvhClip clip;
  try {
    clip = vc::body::parse_bvh(text, "fuzz");
  } catch (const std::runtime_error&) {
    return 0;
  }
  if (clip.values.size() !=
      static_cast<std::size_t>(clip.frames) * static_cast<std::size_t>(clip.channel_count)) {
    __builtin_trap();
  }
  if (clip.channels.size() != clip.skeleton.joints.size() ||
      clip.first_channel.size() != clip.skeleton.joints.size()) {
    __builtin_trap();
  }
  std::vector<glm::dvec3> p;
  for (int f = 0; f < clip.frames && f < 4; ++f)
    vc::body::forward_kinematics(clip.skeleton, clip.pose(f, 0.01), &p);
  try {
    const vc::body::HumanoidClip h = vc::body::map_humanoid(clip, "fuzz");
    if (h.map.frames > 0) vc::body::forward_kinematics(h.skeleton, h.sample(0.5 * h.length_s()), &p);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
