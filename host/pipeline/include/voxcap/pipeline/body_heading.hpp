// The performer's right, as the fit last measured it, for the stages before it (host/pipeline/README.md,
// "Body heading"). The fit stage publishes the level x axis of a fitted frame's torso (the hull's PCA,
// signed by continuity: a cue that does not come from the features' left/right names); the
// triangulation stage reads the latest one when it names the hands and feet of a later frame. The two
// stages run on their own threads: one mutex, a few words copied.
#pragma once

#include <array>
#include <cstdint>
#include <mutex>
#include <optional>

namespace vc::pipeline {

class BodyHeading {
 public:
  struct Sample {
    uint64_t seq = 0;               // the frame it was measured on
    std::array<double, 3> right{};  // unit, level (z = 0), world frame
  };
  // Publishes frame `seq`'s torso right (any length; its level part is kept, normalized). A right
  // with no level part (under 1e-6), not finite, or older than the last one published, is ignored.
  void publish(uint64_t seq, const std::array<double, 3>& right);
  std::optional<Sample> latest() const;

 private:
  mutable std::mutex m_;
  std::optional<Sample> last_;
};

}  // namespace vc::pipeline
