// The viewer's WebSocket messages (host/view/PROTOCOL.md is the normative description; the page's
// web/protocol.js decodes them): one binary message per item, little-endian, each starting with a
// 4-byte header {u8 type, u8 version, u16 flags}. The hull goes as the merged RLE the rig already has
// (no expansion on the host), the pose and the features as float32, the low-rate items (hello, stats,
// replay state) as UTF-8 JSON after the header. Pure functions, no I/O: unit-tested byte for byte.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "voxcap/pipeline/frame.hpp"

namespace vc::config {
struct RigConfig;
}

namespace vc::view {

inline constexpr uint8_t kProtocolVersion = 1;

enum class MsgType : uint8_t {
  Hello = 1,       // JSON: the rig (grid, cameras, nodes, joints, bones); first message on every connection
  Hull = 2,        // the merged hull, RLE
  Pose = 3,        // the fitted skeleton, 15 joints
  Features3D = 4,  // the triangulated features
  Features2D = 5,  // every camera's 2D features of the frame
  Silhouette = 6,  // one camera's mask preview, RLE
  Stats = 7,       // JSON: node health, stage timings, recording, sessions (about 2 Hz)
  Replay = 8,      // JSON: the replay's state (session, frames, index, playing)
};

// Caps on what one message may carry (a frame over them is cut, never sent unbounded).
inline constexpr size_t kMaxHullRle = 16u << 20;       // bytes of RLE
inline constexpr size_t kMaxSilhouetteRle = 4u << 20;  // bytes of RLE
inline constexpr size_t kMaxFeatureCameras = 255;      // camera entries in one Features2D

// Rig camera index of `node`'s camera `cam` (calibration order), from the rig's [[nodes]] cameras;
// -1 when unknown.
int rig_camera_index(const config::RigConfig& rig, uint16_t node_id, uint16_t cam);

// The messages of one frame; each returns the message bytes (std::string: what WebSocket writes take).
std::string encode_hull(const pipeline::Frame& f);
std::string encode_pose(const pipeline::Frame& f);        // empty when the frame has no pose
std::string encode_features3d(const pipeline::Frame& f);  // empty when the frame was not triangulated
// rig may be null (rig camera index then 0xFFFF).
std::string encode_features2d(const pipeline::Frame& f, const config::RigConfig* rig);
std::string encode_silhouette(const pipeline::Frame& f, const pipeline::NodePart& part,
                              const pipeline::Silhouette& s, const config::RigConfig* rig);
// A JSON message (Hello, Stats, Replay): header + the text.
std::string encode_json(MsgType type, std::string_view json);

// The Hello JSON of a rig: {"protocol":1,"rig":name,"mode":mode,"grid":{...},"cameras":[...],
// "nodes":[...],"joints":[...],"bones":[[a,b],...],"features":[...]} (PROTOCOL.md).
std::string hello_json(const config::RigConfig& rig, std::string_view mode);

// The pose as the documented JSON of the /pose.json path: {"seq":..,"t_trigger_ns":..,"state":"fitted",
// "confidence":..,"joints":{"hips":[x,y,z],...}} (metres, world frame); empty without a pose.
std::string pose_json(const pipeline::Frame& f);

}  // namespace vc::view
