#include "voxcap/edge/track/producer.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <new>

namespace vc::track {

Producer::Producer(const TrackerOptions& options, const Seeder& seeder)
    : trackers_{CameraTracker(options, seeder), CameraTracker(options, seeder)} {}

void Producer::reset() {
  for (auto& t : trackers_) t.reset();
  have_seq_ = false;
}

void to_features(const FrameReport& report, std::uint16_t camera, vc_features* out) {
  std::memset(out, 0, sizeof(*out));
  out->camera = camera;
  out->feature_count = kFeatures;
  for (int f = 0; f < kFeatures; ++f) {
    const FeatureReport& r = report[static_cast<std::size_t>(f)];
    vc_feature& o = out->features[f];
    o.feature_id = static_cast<std::uint16_t>(f);
    o.state = static_cast<std::uint16_t>(r.state);
    const bool finite = std::isfinite(r.uv.x) && std::isfinite(r.uv.y);
    o.u = r.state == FeatureState::not_visible || !finite ? 0.0f : r.uv.x;
    o.v = r.state == FeatureState::not_visible || !finite ? 0.0f : r.uv.y;
    if (!finite && r.state != FeatureState::not_visible) o.state = VC_FEATURE_NOT_VISIBLE;
    o.confidence = std::isfinite(r.confidence) ? std::fmin(1.0f, std::fmax(0.0f, r.confidence)) : 0.0f;
  }
}

int Producer::track(std::uint64_t seq, const std::uint8_t* const rgb[kCameras],
                    const std::size_t stride[kCameras], const std::uint8_t* const mask[kCameras],
                    const int width[kCameras], const int height[kCameras],
                    vc_features out[kCameras]) noexcept {
  for (int c = 0; c < kCameras; ++c) {
    if (!rgb[c] || !mask[c] || width[c] <= 0 || height[c] <= 0 || width[c] > 16384 || height[c] > 16384 ||
        stride[c] < static_cast<std::size_t>(width[c]) * 3)
      return -EINVAL;
  }
  if (have_seq_ && seq <= last_seq_) reset();
  have_seq_ = true;
  last_seq_ = seq;
  try {
    for (int c = 0; c < kCameras; ++c) {
      // Borrowed, read-only views: OpenCV's Mat has no const-data constructor.
      const cv::Mat3b image(height[c], width[c],
                            reinterpret_cast<cv::Vec3b*>(const_cast<std::uint8_t*>(rgb[c])), stride[c]);
      const cv::Mat1b silhouette(height[c], width[c], const_cast<std::uint8_t*>(mask[c]));
      FrameReport report;
      trackers_[static_cast<std::size_t>(c)].process(image, silhouette, &report);
      to_features(report, static_cast<std::uint16_t>(c), &out[c]);
    }
  } catch (const std::bad_alloc&) {
    return -ENOMEM;
  } catch (...) {
    return -EIO;
  }
  frames_++;
  return kCameras;
}

}  // namespace vc::track
