// The rig configuration (rig.toml): which edge nodes there are and which cameras each drives, the
// calibration file, the voxel grid, the edges' subtraction thresholds, which nodes track features, the
// trigger, the frame-assembly deadline, the recording folder and the host's listen address. The file
// layout is documented in host/config/README.md; hw/rigs/ holds examples.
//
// load_rig_config() is the ONE place where TOML becomes option structs. Every error is a ConfigError
// whose message names the file and the key path, e.g.
//   "rig.toml: trigger.rate_hz: must be in (0, 1000], got 0 (line 12)"
// Unknown keys are errors (a typo must not silently fall back to a default).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "voxcap/config/options.hpp"
#include "voxcap/rig/calibration.hpp"
#include "voxcap/rig/voxel_grid.hpp"

namespace vc::config {

class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, std::string key, std::string problem, int line = 0);
  const std::string& file() const { return file_; }
  const std::string& key() const { return key_; }  // "trigger.rate_hz"; empty for file-level errors
  int line() const { return line_; }               // 0 when unknown

 private:
  std::string file_, key_;
  int line_;
};

// [triangulation]: how the host's triangulation stage (host/triangulate) turns the edges' 2D features
// into 3D ones. Defaults are documented in host/config/README.md and host/triangulate/README.md.
struct TriangulationOptions {
  bool enabled = true;            // run the stage (voxcap-host, voxcap rig)
  double min_confidence = 0.2;    // a view counts when its feature's confidence is above this, 0..1
  double predicted_weight = 0.5;  // weight of a `predicted` view against a `tracking` one, 0..1
  double inlier_px = 6.0;         // a view agrees with a point when it reprojects within this, pixels
  int refine_iterations = 5;      // Gauss-Newton steps on the reprojection error, 0..50
  double confident = 0.5;         // the documented threshold: a feature above it is within 10 cm
  double swap_ratio = 0.5;        // a camera's left/right is decided when one assignment's error is
                                  // below this fraction of the other's, else it keeps its last, 0..1
  int identity_gap_frames = 30;   // both sides unseen longer than this: left/right named afresh, 1..100000

  bool valid(std::string* why) const;
};

// [fitting]: the host's skeleton fitting stage (host/fit, the method's section 8). Defaults are
// documented in host/config/README.md and host/fit/README.md.
enum class Smoothing { None, OneEuro };
struct FittingOptions {
  bool enabled = true;       // run the "fit" stage after triangulation (voxcap-host, voxcap rig)
  int samples = 256;         // cylinder samples per limb (upper + lower segment), 8..4096
  int steps = 15;            // the method's nu: angles tried per layer-2 search, 1..360
  double span_deg = 45;      // the method's s: the search covers rho(t-1) +- s, (0, 180]
  double k = 4;              // the match score is n^k, [1, 16]
  double straight_deg = 10;  // a limb bent less than this keeps rho(t-1) (the method's skip), [0, 90)
  Smoothing smoothing = Smoothing::None;  // output smoothing of the joint positions
  double one_euro_min_cutoff = 1.0;       // Hz, > 0
  double one_euro_beta = 0.5;             // >= 0
  std::filesystem::path body;             // optional body.toml overriding the automatic body model (absolute,
                                          // resolved against the rig.toml's folder); empty: none
  int init_frames = 10;                   // initialization frames averaged for the body model, 1..600
  int reinit_after_frames = 15;    // the fit failing this many frames in a row re-initializes, 1..100000
  int predict_frames = 30;         // a lost feature is predicted for at most this many frames, 0..100000
  bool follow_pair_swaps = false;  // take a hand/foot pair crosswise when its limbs' paths say the
                                   // triangulation swapped the names (host/fit/README.md); off: it can
                                   // lock in a wrong swap on long takes

  bool valid(std::string* why) const;
};

enum class GridSource { Config, Calibration };  // [grid] in rig.toml wins over the calibration's grid

struct RigConfig {
  std::filesystem::path source;            // the rig.toml as given
  std::string name;                        // [rig] name; default: the file's stem
  std::filesystem::path calibration_path;  // absolute, resolved against the rig.toml's folder
  // The rig key file (`key`, made by `voxcap key new`), absolute; empty: a keyless rig, which is valid
  // only when every address is loopback (network.listen, nodes[].address).
  std::filesystem::path key_path;
  rig::Calibration calibration;  // loaded from calibration_path
  rig::VoxelGrid grid;
  GridSource grid_source = GridSource::Config;
  std::vector<NodeConfig> nodes;
  SubtractionOptions subtraction;
  FeatureOptions features;
  TrackingOptions tracking;
  CarvingOptions carving;
  SilhouetteOptions silhouettes;
  TriangulationOptions triangulation;
  FittingOptions fitting;
  TriggerOptions trigger;
  AssemblyOptions assembly;
  RecordingOptions recording;
  NetworkOptions network;
  HilOptions hil;                     // [hil]: what `voxcap hil` tests (tests/hil/README.md)
  VmcOptions vmc;                     // [vmc]: the live pose stream out (host/stream)
  ViewerOptions viewer;
  std::vector<std::string> warnings;  // legal but suspicious ("3 udp targets for 2 nodes")

  // Cross-section checks (each section's own valid() included): node ids and camera assignments
  // against the calibration, tracking nodes for features, trigger targets against nodes.
  bool valid(std::string* why) const;
  const NodeConfig* node(std::string_view id) const;  // nullptr if absent
  // Whether every address of the rig is loopback (network.listen; nodes[].address "any" or loopback).
  bool loopback_only() const;
  std::vector<const NodeConfig*> front_nodes() const;
  // Whether `node` tracks head, hands and feet: features enabled, and its `track` key, else
  // [tracking] nodes ("all", or "front": its role). What the host puts in CONFIG's feature_role.
  bool tracks(const NodeConfig& node) const;
  std::vector<const NodeConfig*> tracking_nodes() const;
  // Index in calibration.cameras of a camera name; -1 if absent.
  int camera_index(std::string_view camera_name) const;
};

struct LoadOptions {
  bool load_calibration = true;  // false: calibration_path is resolved but not read (grid from [grid])
};

// What a rig.toml may hold (a real one is a few KB).
inline constexpr std::size_t kMaxRigTomlBytes = std::size_t{1} << 20;

// Reads, parses and validates a rig.toml (and its calibration file). Throws ConfigError, one line. Only
// a regular file of at most kMaxRigTomlBytes is read (a FIFO is refused at once); numbers must be
// finite, integers within their key's range, and the grid within the protocol's limits (what the host
// can encode in CONFIG: VC_PROTO_MAX_VOXELS).
RigConfig load_rig_config(const std::filesystem::path& path, const LoadOptions& options = {});
// The same from text; `source` names the file in messages and anchors relative paths.
RigConfig parse_rig_config(std::string_view toml_text, const std::filesystem::path& source,
                           const LoadOptions& options = {});

// The node number `id` is or ends in ("node12" → 12, "7" → 7), or nothing with the reason in *why
// ("'front' must be or end in the node's number (0..65535)", "node number 70000 is over 65535").
std::optional<uint16_t> parse_node_number(std::string_view id, std::string* why = nullptr);
// The protocol's node id of rig node `node` (nodes[k] of `file`): NodeConfig::number, or for a node
// built without it, parsed from its id. Throws ConfigError naming nodes[k].id when there is none.
uint16_t node_number(const NodeConfig& node, size_t k, const std::string& file);

// The rig.toml to use when none is given: $VOXCAP_RIG, else ./rig.toml if it exists, else the
// emulated example rig of the source tree (hw/rigs/emulated.toml).
std::filesystem::path default_rig_config_path();

}  // namespace vc::config
