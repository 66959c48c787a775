#include "voxcap/pipeline/body_heading.hpp"

#include <cmath>

namespace vc::pipeline {

void BodyHeading::publish(uint64_t seq, const std::array<double, 3>& right) {
  const double n = std::hypot(right[0], right[1]);
  if (!std::isfinite(n) || n < 1e-6) return;
  const std::lock_guard<std::mutex> lock(m_);
  if (last_ && seq < last_->seq) return;
  last_ = Sample{seq, {right[0] / n, right[1] / n, 0.0}};
}

std::optional<BodyHeading::Sample> BodyHeading::latest() const {
  const std::lock_guard<std::mutex> lock(m_);
  return last_;
}

}  // namespace vc::pipeline
