// The virtual rig: a performer driven by a motion, in a static textured room, lit by one point
// light that also casts the performer's shadow on the floor, seen by calibrated cameras with
// sensor noise and optional illumination flicker. Renders camera images (interleaved RGB) and the
// ground truth: silhouettes, shadow masks, 3D joints, 2D features with visibility, occupancy.
//
// Deterministic: the same options (incl. seed) give the same pixels on every run and machine.
// Thread-safe: every const member may be called concurrently (per-camera caches are built once,
// lazily, under std::call_once).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "voxcap/rig/calibration.hpp"
#include "voxcap/sim/body.hpp"
#include "voxcap/sim/motion.hpp"
#include "voxcap/sim/rig_layout.hpp"

namespace vc::sim {

// The room around the volume (hw/sim/README.md, "Rooms"): "default" (a wooden floor, off-white walls
// with posters in colours close to the clothes) and "camouflage" (a beige tiled floor close to the skin
// presets, walls painted close to the shirt presets). Procedural: the same pixels everywhere.
struct RoomPreset {
  std::string name;
  std::string description;
};
const std::vector<RoomPreset>& room_presets();

struct SceneOptions {
  MotionOptions motion;  // incl. fps (the camera rate)
  BodyDescription body;
  std::string appearance = "default";           // appearance_presets()
  std::string room = "default";                 // room_presets()
  RigLayout rig;                                // used when calibration is empty
  std::optional<rig::Calibration> calibration;  // e.g. read_calibration("rig.yaml")
  double noise_sigma = 2.0;                     // Gaussian sensor noise, 8-bit levels, per pixel and channel
  double flicker = 0.0;                         // illumination flicker: a global gain in [1-f, 1+f] per frame
  std::uint64_t seed = 1;
  bool shadows = true;
  double shadow_factor = 0.6;        // a shadowed floor pixel is this times the lit one (same hue)
  cv::Vec3d light_m{1.2, 0.9, 2.9};  // the point light (shading and the floor shadow)
  double room_half_m = 4.5;          // the room is [-h, h]^2 x [0, room_height_m] (grown to hold the cameras)
  double room_height_m = 3.0;

  bool valid(std::string* why) const;
};

struct FeatureTruth {
  Feature feature = Feature::head;
  cv::Point2d uv;         // projection of the feature's joint (Camera::project, with distortion)
  double depth_m = 0;     // z in the camera frame
  bool in_image = false;  // in front of the camera and inside the image rectangle
  bool occluded = false;  // the line of sight hits another body part first (see README)
  bool visible = false;   // in_image && !occluded
};

class Scene {
 public:
  // Throws std::invalid_argument (bad options, unknown motion/appearance) or std::runtime_error
  // (unreadable BVH).
  explicit Scene(const SceneOptions& options);
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  const SceneOptions& options() const;
  const rig::Calibration& calibration() const;
  const Motion& motion() const;
  int camera_count() const;
  double fps() const;

  // One camera frame: CV_8UC3 RGB with noise and flicker; optionally the true silhouette
  // (CV_8UC1, 255 = a body pixel of this very image) and shadow mask (255 = a floor pixel in the
  // performer's shadow, not covered by the body).
  void render(int frame, int cam, cv::Mat& rgb_out, cv::Mat* silhouette_truth = nullptr,
              cv::Mat* shadow_truth = nullptr) const;
  // The same without noise and flicker (the silhouette is identical).
  void render_clean(int frame, int cam, cv::Mat& rgb_out, cv::Mat* silhouette_truth = nullptr,
                    cv::Mat* shadow_truth = nullptr) const;
  // The i-th frame of the empty room (noise and flicker drawn independently of the frames).
  void render_background(int cam, int i, cv::Mat& rgb_out) const;
  void render_background_clean(int cam, cv::Mat& rgb_out) const;

  BodyPose body_pose(int frame) const;
  std::array<cv::Vec3d, kJointCount> joints(int frame) const;
  std::vector<FeatureTruth> features(int frame, int cam) const;
  // Point-in-body test (points below the floor are never occupied).
  bool occupied(const cv::Vec3d& p_world, int frame) const;
  // Occupancy of every voxel centre, as a hull bitset (bit i + nx*(j + ny*k), LSB-first).
  void occupancy(const rig::VoxelGrid& grid, int frame, std::vector<std::uint8_t>* bits) const;
  // The same as a part label per voxel centre (index i + nx*(j + ny*k), one byte each): the Part
  // index of a primitive holding it, or kNoPart. Where parts overlap (at the joints) the highest
  // Part index wins, i.e. the part further out along its limb (a hand over its forearm, the toes
  // over the foot, the head over the neck, an upper arm over the shoulder girdle). A voxel is
  // labelled exactly when occupancy() sets its bit.
  static constexpr std::uint8_t kNoPart = 0xFF;
  void occupancy_parts(const rig::VoxelGrid& grid, int frame, std::vector<std::uint8_t>* part) const;
  std::vector<Primitive> primitives(int frame) const;

  // Global illumination gain of a frame (1 without flicker).
  double flicker_gain(int frame) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace vc::sim
