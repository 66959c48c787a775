// The FEATURES producer of a tracking node: one CameraTracker per camera, fed with the node's frame pair
// and silhouettes, turned into one vc_features (proto) per camera per frame, lost and unseen features
// included (the state says so). The edge daemon wraps it in node.h's vc_features_producer hook.
//
// Lifecycle: reset() at every START (a new initialization: the performer stands in the init pose again);
// track() on every processed frame. A seq that does not increase also starts anew (a node that was
// restarted or re-CONFIGured). No allocation per frame once both trackers are past initialization,
// except what OpenCV allocates inside its calls and re-acquisition's labelling while a feature is lost.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "voxcap/edge/track/tracker.hpp"
#include "voxcap/proto.h"

namespace vc::track {

class Producer {
 public:
  static constexpr int kCameras = 2;

  // Throws std::invalid_argument for invalid options.
  explicit Producer(const TrackerOptions& options = {}, const Seeder& seeder = nullptr);

  void reset();
  // One frame pair: rgb[c] (RGB24, stride[c] bytes per row), mask[c] (width*height bytes, 0/255). Fills
  // out[0..1] (camera c, five features) and returns 2, or a negative errno (-EINVAL for a null image or a
  // bad size, -ENOMEM, -EIO for any other failure) without throwing.
  int track(std::uint64_t seq, const std::uint8_t* const rgb[kCameras], const std::size_t stride[kCameras],
            const std::uint8_t* const mask[kCameras], const int width[kCameras], const int height[kCameras],
            vc_features out[kCameras]) noexcept;

  const CameraTracker& camera(int c) const { return trackers_[static_cast<std::size_t>(c)]; }
  std::uint64_t frames() const { return frames_; }

 private:
  std::array<CameraTracker, kCameras> trackers_;
  std::uint64_t last_seq_ = 0;
  bool have_seq_ = false;
  std::uint64_t frames_ = 0;
};

// A FrameReport as the wire's vc_features of camera `camera`.
void to_features(const FrameReport& report, std::uint16_t camera, vc_features* out);

}  // namespace vc::track
