// The tracking part of `voxcap bench edge` (`track.*`): one node's pair of cameras of the virtual rig
// (hw/sim, the `wave` motion from its init pose, noise and shadows on), the edge's own masks
// (edge/core subtraction + clean-up), and edge/track's Producer timed per call: initialization frames
// (seeding and colour learning) and tracking frames (CamShift per feature, loss checks, re-acquisition)
// apart, per camera. Keys in tests/bench/README.md.
#pragma once

#include <nlohmann/json.hpp>

namespace vc::bench {

nlohmann::json run_track_bench(int width, int height, int frames);

}  // namespace vc::bench
