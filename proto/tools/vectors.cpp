// The test-vector generator (see vectors.hpp). Each vector is built from message structures: valid
// messages through the library's encoders, rejections by patching documented payload offsets of a
// valid message and re-sealing its CRCs (or, for framing errors, by corrupting the frame). The
// expected events are written from the structures and from what each corruption must cause, never
// by running the decoder. All values are exact binary fractions or integers, so the JSON prints the
// same everywhere.
#include "vectors.hpp"

#include <algorithm>
#include <fstream>
#include <functional>
#include <optional>
#include <stdexcept>

#include <fmt/core.h>

#include "voxcap/auth.h"
#include "voxcap/crc32c.h"
#include "voxcap/proto.h"
#include "voxcap/proto_json.hpp"
#include "voxcap/rle.h"

namespace vc::proto::vectors {
namespace {

using Bytes = std::vector<uint8_t>;

uint16_t ld16(const uint8_t* p) {
  return static_cast<uint16_t>(p[0] | (p[1] << 8));
}
uint32_t ld32(const uint8_t* p) {
  return p[0] | (p[1] << 8) | (p[2] << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
void st16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
void st32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; i++) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
void st64(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; i++) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

std::string hex(const Bytes& b) {
  std::string s;
  for (uint8_t x : b) s += fmt::format("{:02x}", x);
  return s;
}

constexpr uint16_t kNode = 3;
constexpr uint64_t kSeq = 1042;
constexpr uint64_t kTrigger = 17'361'000'000ull;  // ns

vc_msg make(uint16_t type, uint64_t seq = 0, uint64_t t = 0) {
  vc_msg m{};
  m.hdr.type = type;
  m.hdr.node_id = kNode;
  m.hdr.seq = seq;
  m.hdr.t_trigger_ns = t;
  m.known = true;
  return m;
}

Bytes encode(const vc_msg& m) {
  Bytes b(VC_PROTO_HEADER_SIZE + (1u << 20));  // every vector message is far smaller
  size_t len = 0;
  int rc = vc_msg_encode(b.data(), b.size(), &len, &m);
  if (rc)
    throw std::runtime_error(fmt::format("encoding type {} failed: {}", m.hdr.type, vc_proto_strerror(rc)));
  b.resize(len);
  return b;
}

// A frame with this header (version as given) around a hand-built payload.
Bytes frame(const vc_header& h, const Bytes& payload) {
  Bytes b(VC_PROTO_HEADER_SIZE + payload.size());
  size_t len = 0;
  int rc = vc_frame_encode(b.data(), b.size(), &len, &h, payload.data(), payload.size());
  if (rc) throw std::runtime_error(fmt::format("framing failed: {}", vc_proto_strerror(rc)));
  return b;
}

Bytes payload_of(const Bytes& msg) {
  return Bytes(msg.begin() + VC_PROTO_HEADER_SIZE, msg.end());
}

// Bit-by-bit RLE, independent of vc_rle_encode.
Bytes reference_rle(const Bytes& bits, size_t nbits) {
  Bytes out;
  auto put = [&](uint64_t v) {
    do {
      uint8_t byte = v & 0x7F;
      v >>= 7;
      out.push_back(v ? static_cast<uint8_t>(byte | 0x80) : byte);
    } while (v);
  };
  bool state = false;
  uint64_t run = 0;
  for (size_t i = 0; i < nbits; i++) {
    bool bit = (bits[i / 8] >> (i % 8)) & 1;
    if (bit != state) {
      put(run);
      state = bit;
      run = 0;
    }
    run++;
  }
  if (nbits) put(run);
  return out;
}

// ---- message contents -------------------------------------------------------------------------------

vc_msg hello_msg() {
  vc_msg m = make(VC_MSG_HELLO);
  vc_hello& h = m.u.hello;
  h.node_id = kNode;
  h.sw_major = 0;
  h.sw_minor = 1;
  h.sw_patch = 0;
  h.capabilities = VC_CAP_HULL | VC_CAP_FEATURES | VC_CAP_UDP_TRIGGER;
  h.camera_count = 2;
  h.camera_record_size = 12;
  for (int i = 0; i < 2; i++) h.cameras[i] = {640, 480, VC_FOURCC('R', 'G', 'B', '3'), 60000};
  return m;
}

vc_msg config_msg() {
  vc_msg m = make(VC_MSG_CONFIG);
  vc_config& c = m.u.config;
  c.grid_id = 7;
  c.grid.nx = c.grid.ny = c.grid.nz = 128;
  c.grid.min_m[0] = -1.28;
  c.grid.min_m[1] = -1.28;
  c.grid.min_m[2] = 0.0;
  c.grid.voxel_m = 0.02;
  c.t_upper = 3.5f;
  c.t_lower = 1.5f;
  c.shadow_angle_deg = 6.0f;
  c.cleanup_radius_px = 3;
  c.carve_rule = VC_CARVE_FOOTPRINT;
  c.silhouette_every = 4;
  c.silhouette_scale = 2;
  c.background_frames = 30;
  c.feature_role = VC_ROLE_FRONT;
  c.camera_count = 2;
  c.camera_record_size = 216;
  // Camera 0 three metres in front (-y) looking along +y; camera 1 rotated 30 degrees about z.
  const double K[9] = {500, 0, 319.5, 0, 500, 239.5, 0, 0, 1};
  const double dist[5] = {-0.125, 0.015625, 0.0009765625, -0.00048828125, 0};
  const double R0[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};
  const double t0[3] = {0, 1.25, 3};
  const double R1[9] = {0.8660254037844387, 0.5, 0, 0, 0, -1, -0.5, 0.8660254037844387, 0};
  const double t1[3] = {0, 1.25, 3};
  for (int i = 0; i < 2; i++) {
    vc_camera& cam = c.cameras[i];
    cam.width = 640;
    cam.height = 480;
    std::copy(K, K + 9, cam.K);
    std::copy(dist, dist + 5, cam.dist);
    std::copy(i ? R1 : R0, (i ? R1 : R0) + 9, cam.R_cam_from_world);
    std::copy(i ? t1 : t0, (i ? t1 : t0) + 3, cam.t_cam_from_world);
  }
  return m;
}

vc_msg background_msg() {
  vc_msg m = make(VC_MSG_BACKGROUND);
  m.u.background.frame_count = 40;
  return m;
}

// A 16x12x10 grid holding an ellipsoid "body" and a one-voxel-thick "arm", in integer arithmetic.
constexpr int kNx = 16, kNy = 12, kNz = 10;
Bytes small_hull_bits() {
  Bytes bits((kNx * kNy * kNz + 7) / 8, 0);
  auto set = [&](int i, int j, int k) {
    size_t b = static_cast<size_t>(i) +
               size_t{kNx} * (static_cast<size_t>(j) + size_t{kNy} * static_cast<size_t>(k));
    bits[b / 8] = static_cast<uint8_t>(bits[b / 8] | (1u << (b % 8)));
  };
  for (int k = 0; k < kNz; k++)
    for (int j = 0; j < kNy; j++)
      for (int i = 0; i < kNx; i++) {
        // Doubled coordinates about the centre (8.5, 5.5, 4.5); semi-axes 6, 4, 4 voxels.
        int dx = 2 * i - 17, dy = 2 * j - 11, dz = 2 * k - 9;
        if (dx * dx * 64 + dy * dy * 144 + dz * dz * 144 <= 144 * 64) set(i, j, k);
      }
  for (int i = 0; i < 5; i++) set(i, 5, 6);
  return bits;
}

struct HullData {
  Bytes rle;
  uint64_t voxels = 0, occupied = 0;
};

HullData hull_data(const Bytes& bits, size_t nbits) {
  HullData d;
  d.voxels = nbits;
  for (size_t i = 0; i < nbits; i++) d.occupied += (bits[i / 8] >> (i % 8)) & 1;
  d.rle = reference_rle(bits, nbits);
  return d;
}

// The HULL message refers to d.rle: d must outlive it.
vc_msg hull_msg(const HullData& d, uint64_t seq = kSeq, uint64_t t = kTrigger) {
  vc_msg m = make(VC_MSG_HULL, seq, t);
  m.u.hull.grid_id = 7;
  m.u.hull.rle_len = static_cast<uint32_t>(d.rle.size());
  m.u.hull.voxel_count = d.voxels;
  m.u.hull.occupied_count = d.occupied;
  m.u.hull.rle = d.rle.data();
  for (uint8_t b : d.rle) m.u.hull.run_count += !(b & 0x80);
  return m;
}

vc_msg features_msg(uint16_t camera = 0, uint64_t seq = kSeq, uint64_t t = kTrigger) {
  vc_msg m = make(VC_MSG_FEATURES, seq, t);
  vc_features& f = m.u.features;
  f.camera = camera;
  f.feature_count = 5;
  f.feature_record_size = 16;
  f.features[0] = {VC_FEATURE_HEAD, VC_FEATURE_TRACKING, 321.5f, 88.25f, 0.96875f};
  f.features[1] = {VC_FEATURE_LEFT_HAND, VC_FEATURE_TRACKING, 180.0f, 200.75f, 0.875f};
  f.features[2] = {VC_FEATURE_RIGHT_HAND, VC_FEATURE_PREDICTED, 455.25f, 198.5f, 0.5f};
  f.features[3] = {VC_FEATURE_LEFT_FOOT, VC_FEATURE_LOST, 290.0f, 430.0f, 0.0f};
  f.features[4] = {VC_FEATURE_RIGHT_FOOT, VC_FEATURE_NOT_VISIBLE, 0.0f, 0.0f, 0.0f};
  if (camera == 1) f.features[2].state = VC_FEATURE_TRACKING;
  return m;
}

vc_msg stats_msg() {
  vc_msg m = make(VC_MSG_STATS, kSeq, kTrigger);
  vc_stats& s = m.u.stats;
  s.frames = 60;
  const uint32_t mean[8] = {2'100'000, 1'450'000, 310'000, 980'000, 120'000, 2'600'000, 90'000, 7'400'000};
  for (uint32_t i = 0; i < 8; i++) s.stages[i] = {i, mean[i], mean[i] + mean[i] / 4};
  s.stage_count = 8;
  const uint64_t counters[8] = {36'000, 35'990, 71'980, 4, 1, 2, 0, 0};
  for (uint32_t i = 0; i < 8; i++) s.counters[i] = {i, counters[i]};
  s.counter_count = 8;
  return m;
}

vc_msg heartbeat_msg(uint32_t state = VC_STATE_READY, uint64_t time_ns = 17'360'123'456ull) {
  vc_msg m = make(VC_MSG_HEARTBEAT);
  m.u.heartbeat.sender_time_ns = time_ns;
  m.u.heartbeat.state = state;
  return m;
}

const std::string kErrorText = "grid 512x512x512 needs a 1.5 GiB LUT \xe2\x80\x94 more than this node has";

vc_msg error_msg() {
  vc_msg m = make(VC_MSG_ERROR);
  m.u.error.code = VC_ERR_CONFIG;
  m.u.error.severity = VC_SEVERITY_ERROR;
  m.u.error.about_type = VC_MSG_CONFIG;
  m.u.error.text_len = static_cast<uint16_t>(kErrorText.size());
  m.u.error.text = kErrorText.data();
  return m;
}

// A 20x15 silhouette (a 40x30 camera at scale 2): an elliptic body and a one-pixel arm, in integers.
constexpr uint16_t kSilW = 20, kSilH = 15;
Bytes silhouette_bits() {
  Bytes bits((kSilW * kSilH + 7) / 8, 0);
  auto set = [&](int x, int y) {
    size_t b = static_cast<size_t>(x) + size_t{kSilW} * static_cast<size_t>(y);
    bits[b / 8] = static_cast<uint8_t>(bits[b / 8] | (1u << (b % 8)));
  };
  for (int y = 0; y < kSilH; y++)
    for (int x = 0; x < kSilW; x++) {
      int dx = 2 * x - 21, dy = 2 * y - 15;  // doubled, about (10.5, 7.5); semi-axes 4, 6 pixels
      if (dx * dx * 36 + dy * dy * 16 <= 16 * 36 * 4) set(x, y);
    }
  for (int x = 2; x < 7; x++) set(x, 4);
  return bits;
}

// The SILHOUETTE refers to d.rle: d must outlive it.
vc_msg silhouette_msg(const HullData& d, uint16_t camera = 0, uint64_t seq = kSeq, uint64_t t = kTrigger) {
  vc_msg m = make(VC_MSG_SILHOUETTE, seq, t);
  vc_silhouette& s = m.u.silhouette;
  s.camera = camera;
  s.scale = 2;
  s.width = kSilW;
  s.height = kSilH;
  s.rle_len = static_cast<uint32_t>(d.rle.size());
  s.foreground_count = static_cast<uint32_t>(d.occupied);
  s.rle = d.rle.data();
  for (uint8_t b : d.rle) s.run_count += !(b & 0x80);
  return m;
}

// ---- 2.4: GRAB and FRAME ----
vc_msg grab_msg(uint16_t every = 15, uint16_t format = VC_FRAME_GRAY8, uint32_t count = 40) {
  vc_msg m = make(VC_MSG_GRAB, kSeq, 0);  // header seq: the first frame to consider
  m.u.grab.every = every;
  m.u.grab.format = format;
  m.u.grab.cameras = 0x3;
  m.u.grab.count = count;
  return m;
}

// A 6x4 camera image: RGB ramps, so every byte differs from its neighbours. Static: messages point at it.
const Bytes& frame_rgb_pixels() {
  static const Bytes px = [] {
    Bytes b;
    for (int y = 0; y < 4; y++)
      for (int x = 0; x < 6; x++)
        b.insert(b.end(), {static_cast<uint8_t>(40 * x + 3), static_cast<uint8_t>(60 * y + 7),
                           static_cast<uint8_t>(200 - 10 * (x + y))});
    return b;
  }();
  return px;
}

vc_msg frame_msg(uint16_t camera = 1, uint16_t format = VC_FRAME_RGB8) {
  vc_msg m = make(VC_MSG_FRAME, kSeq, kTrigger);
  vc_frame_msg& f = m.u.frame;
  f.camera = camera;
  f.format = format;
  f.width = 6;
  f.height = 4;
  static Bytes gray;
  if (format == VC_FRAME_GRAY8) {
    const Bytes& rgb = frame_rgb_pixels();
    gray.clear();
    for (size_t i = 0; i < rgb.size(); i += 3)
      gray.push_back(static_cast<uint8_t>((77u * rgb[i] + 150u * rgb[i + 1] + 29u * rgb[i + 2] + 128u) >> 8));
    f.pixels = gray.data();
    f.pixels_len = static_cast<uint32_t>(gray.size());
  } else {
    f.pixels = frame_rgb_pixels().data();
    f.pixels_len = static_cast<uint32_t>(frame_rgb_pixels().size());
  }
  return m;
}

// ---- vectors -----------------------------------------------------------------------------------------

struct Vector {
  std::string name, description;
  size_t max_payload = 0;  // 0: VC_PROTO_MAX_PAYLOAD
  Bytes bytes;
  Json events = Json::array();
  // Authenticated streams (2.3): what the receiver's MAC state is derived from ("mac" in the .json:
  // the rig key, node id, both nonces, the direction and its first counter, and the derived MAC key),
  // and for the handshake vector the inputs of its proofs ("auth"). Null: a plain stream.
  Json mac, auth;

  // A valid message; `wire` overrides the encoder's bytes (newer versions built by hand).
  void message(vc_msg m, std::optional<Bytes> wire = std::nullopt, uint32_t ignored = 0) {
    Bytes b = wire ? *wire : encode(m);
    m.hdr.version_major = b[4];
    m.hdr.version_minor = b[5];
    m.hdr.type = ld16(b.data() + 6);
    m.hdr.payload_len = ld32(b.data() + 12);
    m.hdr.payload_crc = ld32(b.data() + 32);
    m.hdr.header_crc = ld32(b.data() + 36);
    m.ignored_bytes = ignored;
    Json e;
    e["offset"] = bytes.size();
    e["message"] = msg_to_json(m);
    events.push_back(e);
    raw(b);
  }
  // Bytes an error event (or nothing) accounts for.
  size_t raw(const Bytes& b) {
    size_t at = bytes.size();
    bytes.insert(bytes.end(), b.begin(), b.end());
    return at;
  }
  void error(size_t offset, int code, std::optional<uint16_t> type = std::nullopt) {
    vc_proto_diag d{};
    d.code = code;
    Json e;
    e["offset"] = offset;
    e["error"] = error_to_json(d, false);
    if (type) e["type"] = vc_msg_type_name(*type) ? Json(vc_msg_type_name(*type)) : Json(*type);
    events.push_back(e);
  }
  // A message rejected with a non-fatal error: consumed, decoding goes on.
  void rejected(const Bytes& b, int code) { error(raw(b), code, ld16(b.data() + 6)); }
  // A valid message sealed with tx (auth.h, vc_mac_seal): the receiver sees the header as sent (flag
  // VC_FLAG_MAC, both CRCs of the sealed frame) with payload_len less the trailer, and the same body.
  void sealed(vc_msg m, const Bytes& wire) {
    Json e;
    m.hdr.version_major = wire[4];
    m.hdr.version_minor = wire[5];
    m.hdr.flags = ld16(wire.data() + 8);
    m.hdr.payload_len = ld32(wire.data() + 12) - VC_AUTH_TRAILER_SIZE;
    m.hdr.payload_crc = ld32(wire.data() + 32);
    m.hdr.header_crc = ld32(wire.data() + 36);
    e["offset"] = bytes.size();
    e["message"] = msg_to_json(m);
    events.push_back(e);
    raw(wire);
  }
};

// ---- authenticated control (2.3): deterministic key and nonces --------------------------------------

struct AuthInputs {
  uint8_t key[VC_AUTH_KEY_SIZE];
  uint8_t nonce_node[VC_AUTH_NONCE_SIZE], nonce_host[VC_AUTH_NONCE_SIZE];
  AuthInputs() {
    for (int i = 0; i < VC_AUTH_KEY_SIZE; i++) key[i] = static_cast<uint8_t>(0x5A ^ (7 * i + 1));
    for (int i = 0; i < VC_AUTH_NONCE_SIZE; i++) {
      nonce_node[i] = static_cast<uint8_t>(0x10 + i);
      nonce_host[i] = static_cast<uint8_t>(0x80 + 3 * i);
    }
  }
  Json json() const {
    Json j;
    j["rig_key"] = hex(Bytes(key, key + VC_AUTH_KEY_SIZE));
    j["node_id"] = kNode;
    j["nonce_node"] = hex(Bytes(nonce_node, nonce_node + VC_AUTH_NONCE_SIZE));
    j["nonce_host"] = hex(Bytes(nonce_host, nonce_host + VC_AUTH_NONCE_SIZE));
    return j;
  }
  // The node -> host direction's MAC state (vc_auth_session), counter 0.
  vc_mac node_to_host() const {
    vc_mac n2h{}, h2n{};
    vc_auth_session(key, kNode, nonce_node, nonce_host, &n2h, &h2n);
    return n2h;
  }
  Json mac_json() const {
    Json j = json();
    const vc_mac m = node_to_host();
    j["direction"] = "node_to_host";
    j["counter"] = m.counter;
    j["mac_key"] = hex(Bytes(m.key, m.key + VC_AUTH_KEY_SIZE));
    return j;
  }
};

vc_msg auth_msg(uint16_t step, const uint8_t* nonce, const uint8_t* proof) {
  vc_msg m = make(VC_MSG_AUTH);
  m.u.auth.step = step;
  if (nonce) std::copy(nonce, nonce + VC_AUTH_NONCE_SIZE, m.u.auth.nonce);
  if (proof) std::copy(proof, proof + VC_AUTH_PROOF_SIZE, m.u.auth.proof);
  return m;
}

// The message sealed with tx (its counter used and advanced).
Bytes seal(const vc_msg& m, vc_mac& tx) {
  Bytes b = encode(m);
  const size_t len = b.size();
  b.resize(len + VC_AUTH_TRAILER_SIZE);
  size_t out = 0;
  int rc = vc_mac_seal(&tx, b.data(), len, b.size(), &out);
  if (rc) throw std::runtime_error(fmt::format("sealing type {} failed: {}", m.hdr.type, rc));
  b.resize(out);
  return b;
}

// Both CRCs recomputed after bytes were changed: the frame is sound, only the MAC can tell.
Bytes recrc(Bytes b) {
  st32(b.data() + 32, vc_crc32c(0, b.data() + VC_PROTO_HEADER_SIZE, b.size() - VC_PROTO_HEADER_SIZE));
  st32(b.data() + 36, vc_crc32c(0, b.data(), 36));
  return b;
}

std::vector<Vector> build_streams() {
  std::vector<Vector> v;
  auto add = [&](std::string name, std::string description) -> Vector& {
    Vector vec;
    vec.name = std::move(name);
    vec.description = std::move(description);
    v.push_back(std::move(vec));
    return v.back();
  };
  const Bytes small_bits = small_hull_bits();
  const HullData small = hull_data(small_bits, kNx * kNy * kNz);
  const HullData empty = hull_data(Bytes((kNx * kNy * kNz + 7) / 8, 0), kNx * kNy * kNz);
  const HullData sil = hull_data(silhouette_bits(), size_t{kSilW} * kSilH);

  // One valid message of each type.
  add("hello",
      "HELLO from node 3: software 0.1.0, two 640x480 RGB3 cameras at 60 fps, hull + features + udp trigger")
      .message(hello_msg());
  add("config",
      "CONFIG for node 3: grid 7 (128^3 voxels of 2 cm), thresholds, footprint carving, a SILHOUETTE "
      "every 4th frame at scale 2, role front, two calibrated cameras")
      .message(config_msg());
  add("background", "BACKGROUND: learn 40 frames of the empty scene").message(background_msg());
  add("start", "START: stream frames (empty payload)").message(make(VC_MSG_START));
  add("stop", "STOP: stop streaming (empty payload)").message(make(VC_MSG_STOP));
  add("hull", "HULL of frame 1042 on grid 7: a 16x12x10 partial hull (ellipsoid body and an arm) as RLE")
      .message(hull_msg(small));
  add("hull_empty", "HULL with no occupied voxel: one empty run of 1920").message(hull_msg(empty));
  add("features", "FEATURES of frame 1042, camera 0: head, hands, feet in each tracking state")
      .message(features_msg());
  add("stats", "STATS: the eight stage timings and eight counters of SPEC.md").message(stats_msg());
  add("heartbeat", "HEARTBEAT from a node in state ready").message(heartbeat_msg());
  add("error", "ERROR from node 3: CONFIG rejected, UTF-8 text").message(error_msg());
  add("silhouette",
      "SILHOUETTE of frame 1042, camera 1: a 20x15 mask (a 40x30 camera at scale 2), body and arm, as RLE")
      .message(silhouette_msg(sil, 1));

  {  // A whole session as the host sees it, both directions interleaved.
    Vector& s = add("session",
                    "A session: HELLO, CONFIG, BACKGROUND, HEARTBEATs, START, two frames of HULL + "
                    "FEATURES from both cameras (the first also with both cameras' SILHOUETTEs), STATS, "
                    "STOP");
    s.message(hello_msg());
    s.message(config_msg());
    s.message(heartbeat_msg(VC_STATE_CONFIGURED, 17'300'000'000ull));
    s.message(background_msg());
    s.message(heartbeat_msg(VC_STATE_READY, 17'350'000'000ull));
    s.message(make(VC_MSG_START));
    for (uint64_t f = 0; f < 2; f++) {
      uint64_t seq = kSeq + f, t = kTrigger + f * 16'666'667ull;
      s.message(hull_msg(f ? empty : small, seq, t));
      s.message(features_msg(0, seq, t));
      s.message(features_msg(1, seq, t));
      if (f == 0)
        for (uint16_t c = 0; c < 2; c++) s.message(silhouette_msg(sil, c, seq, t));
    }
    s.message(stats_msg());
    s.message(make(VC_MSG_STOP));
  }
  {  // Evolution: an unknown type is skipped, not fatal.
    Vector& u = add("unknown_type",
                    "A message of type 77 (unknown to 2.2) with valid CRCs: reported as unknown and "
                    "skipped; the HEARTBEAT after it decodes");
    vc_msg m = make(77, 5, 6);
    m.known = false;
    Bytes payload{'f', 'u', 't', 'u', 'r', 'e'};
    vc_header h = m.hdr;
    h.version_major = VC_PROTO_VERSION_MAJOR;
    h.version_minor = VC_PROTO_VERSION_MINOR;
    Bytes b = frame(h, payload);
    m.payload = b.data() + VC_PROTO_HEADER_SIZE;
    u.message(m, b);
    u.message(heartbeat_msg());
  }
  {  // Evolution: a newer minor version appends fields; a 2.2 receiver ignores them.
    Vector& n = add("newer_minor",
                    "HELLO 2.3 with 16-byte camera records and 6 appended bytes, HULL 2.4 with 3 "
                    "appended bytes: decoded by a 2.2 receiver, the unknown bytes counted in ignored_bytes");
    vc_msg hello = hello_msg();
    Bytes p = payload_of(encode(hello));
    Bytes q(p.begin(), p.begin() + 16);
    st16(q.data() + 14, 16);
    for (int c = 0; c < 2; c++) {
      q.insert(q.end(), p.begin() + 16 + 12 * c, p.begin() + 28 + 12 * c);
      q.insert(q.end(), {0xAA, 0xBB, 0xCC, 0xDD});
    }
    q.insert(q.end(), {1, 2, 3, 4, 5, 6});
    hello.hdr.version_major = VC_PROTO_VERSION_MAJOR;
    hello.hdr.version_minor = VC_PROTO_VERSION_MINOR + 1;
    hello.u.hello.camera_record_size = 16;
    n.message(hello, frame(hello.hdr, q), 2 * 4 + 6);
    vc_msg hull = hull_msg(small);
    Bytes hp = payload_of(encode(hull));
    hp.insert(hp.end(), {0xEE, 0xEE, 0xEE});
    hull.hdr.version_major = VC_PROTO_VERSION_MAJOR;
    hull.hdr.version_minor = VC_PROTO_VERSION_MINOR + 2;
    n.message(hull, frame(hull.hdr, hp), 3);
  }

  // ---- rejections: framing (fatal) ----
  {
    Vector& r = add("bad_magic",
                    "A HEARTBEAT, then bytes that are not a message (an HTTP request): fatal "
                    "VC_PROTO_EMAGIC at the second message's offset");
    r.message(heartbeat_msg());
    std::string http = "GET / HTTP/1.1\r\nHost: voxcap\r\n\r\n";
    r.error(r.raw(Bytes(http.begin(), http.end())), VC_PROTO_EMAGIC);
  }
  {
    Vector& r = add("bad_major", "A HEARTBEAT from protocol version 3.0: fatal VC_PROTO_EVERSION");
    vc_msg m = heartbeat_msg();
    m.hdr.version_major = VC_PROTO_VERSION_MAJOR + 1;
    m.hdr.version_minor = 0;
    m.hdr.type = VC_MSG_HEARTBEAT;
    r.error(r.raw(frame(m.hdr, payload_of(encode(heartbeat_msg())))), VC_PROTO_EVERSION);
  }
  {
    Vector& r =
        add("bad_header_crc", "A HULL whose seq was altered after sealing: fatal VC_PROTO_EHEADER_CRC");
    Bytes b = encode(hull_msg(small));
    b[16] ^= 0x01;
    r.error(r.raw(b), VC_PROTO_EHEADER_CRC);
  }
  {
    Vector& r = add("bad_payload_crc",
                    "A START, then a HULL with one payload byte altered after sealing: fatal "
                    "VC_PROTO_EPAYLOAD_CRC");
    r.message(make(VC_MSG_START));
    Bytes b = encode(hull_msg(small));
    b[VC_PROTO_HEADER_SIZE + 30] ^= 0x40;
    r.error(r.raw(b), VC_PROTO_EPAYLOAD_CRC);
  }
  {
    Vector& r = add("oversize",
                    "A START, then a HULL header announcing VC_PROTO_MAX_PAYLOAD + 1 bytes (header CRC "
                    "valid): fatal VC_PROTO_EOVERSIZE before any payload arrives");
    r.message(make(VC_MSG_START));
    Bytes b = encode(hull_msg(empty));
    b.resize(VC_PROTO_HEADER_SIZE);
    st32(b.data() + 12, VC_PROTO_MAX_PAYLOAD + 1);
    st32(b.data() + 36, vc_crc32c(0, b.data(), 36));
    r.error(r.raw(b), VC_PROTO_EOVERSIZE);
  }
  {
    Vector& r = add("oversize_receiver_limit",
                    "A noisy HULL of more than 1024 payload bytes sent to a receiver "
                    "created with max_payload 1024: fatal VC_PROTO_EOVERSIZE");
    r.max_payload = 1024;
    const size_t nbits = 4 * kNx * kNy * kNz;  // ~3800 runs of 1-2 bytes
    Bytes bits(nbits / 8);
    uint32_t lcg = 12345;
    for (auto& x : bits) {
      lcg = lcg * 1664525u + 1013904223u;
      x = static_cast<uint8_t>(lcg >> 24);
    }
    const HullData noisy = hull_data(bits, nbits);
    r.error(r.raw(encode(hull_msg(noisy))), VC_PROTO_EOVERSIZE);
  }
  {
    Vector& r = add("truncated_stream",
                    "A HEARTBEAT, then the first 50 bytes of a HULL and the end of the stream: "
                    "fatal VC_PROTO_EEOF at the HULL's offset");
    r.message(heartbeat_msg());
    Bytes b = encode(hull_msg(small));
    b.resize(50);
    r.error(r.raw(b), VC_PROTO_EEOF);
  }
  // ---- rejections: one bad message (non-fatal; the stream goes on) ----
  auto patched = [](const vc_msg& m, const std::function<void(Bytes&)>& patch) {
    Bytes b = encode(m);
    Bytes p = payload_of(b);
    patch(p);
    vc_header h = m.hdr;
    h.version_major = VC_PROTO_VERSION_MAJOR;
    h.version_minor = VC_PROTO_VERSION_MINOR;
    return frame(h, p);
  };
  {
    Vector& r = add("truncated_payload",
                    "A HULL whose payload is 20 bytes, shorter than its 24-byte fixed part "
                    "(CRCs valid): VC_PROTO_ETRUNCATED; the HEARTBEAT after it decodes");
    r.rejected(patched(hull_msg(small), [](Bytes& p) { p.resize(20); }), VC_PROTO_ETRUNCATED);
    r.message(heartbeat_msg());
  }
  {
    Vector& r =
        add("truncated_records", "A FEATURES announcing 5 records but carrying 4: VC_PROTO_ETRUNCATED");
    r.rejected(patched(features_msg(), [](Bytes& p) { p.resize(p.size() - 16); }), VC_PROTO_ETRUNCATED);
  }
  {
    Vector& r = add("trailing_bytes",
                    "A 2.1 HEARTBEAT with 4 bytes after its last field: VC_PROTO_ETRAILING; the "
                    "STOP after it decodes");
    r.rejected(patched(heartbeat_msg(),
                       [](Bytes& p) {
                         p.insert(p.end(), {0, 0, 0, 0});
                       }),
               VC_PROTO_ETRAILING);
    r.message(make(VC_MSG_STOP));
  }
  {
    Vector& r = add("inconsistent_popcount",
                    "A HULL whose occupied_count is one more than its occupied runs sum "
                    "to: VC_PROTO_EINCONSISTENT; the next HULL decodes");
    r.rejected(patched(hull_msg(small), [&](Bytes& p) { st64(p.data() + 16, small.occupied + 1); }),
               VC_PROTO_EINCONSISTENT);
    r.message(hull_msg(small, kSeq + 1, kTrigger + 16'666'667ull));
  }
  {
    Vector& r = add("inconsistent_voxel_count",
                    "A HULL whose voxel_count (1921) is not the sum of its runs (1920): "
                    "VC_PROTO_EINCONSISTENT");
    r.rejected(patched(hull_msg(small), [&](Bytes& p) { st64(p.data() + 8, small.voxels + 1); }),
               VC_PROTO_EINCONSISTENT);
  }
  {
    Vector& r = add("inconsistent_record_size",
                    "A 2.1 CONFIG whose camera_record_size is 208, not 216: "
                    "VC_PROTO_EINCONSISTENT");
    r.rejected(patched(config_msg(), [](Bytes& p) { st16(p.data() + 76, 208); }), VC_PROTO_EINCONSISTENT);
  }
  {
    Vector& r = add("bad_rle", "A HULL whose RLE holds an overlong varint (0x8a 0x00): VC_PROTO_ERLE");
    r.rejected(patched(hull_msg(empty),
                       [](Bytes& p) {
                         p.resize(24);
                         p.insert(p.end(), {0x8A, 0x00, 0x80, 0x0F});
                         st32(p.data() + 4, 4);
                       }),
               VC_PROTO_ERLE);
  }
  {
    Vector& r =
        add("too_many_cameras", "A HELLO with camera_count 9 > VC_PROTO_MAX_CAMERAS: VC_PROTO_ELIMIT");
    r.rejected(patched(hello_msg(),
                       [](Bytes& p) {
                         Bytes cam(p.begin() + 16, p.begin() + 28);
                         p.resize(16);
                         for (int i = 0; i < 9; i++) p.insert(p.end(), cam.begin(), cam.end());
                         st16(p.data() + 12, 9);
                       }),
               VC_PROTO_ELIMIT);
  }
  {
    Vector& r = add("duplicate_feature", "A FEATURES listing left_hand twice: VC_PROTO_EINCONSISTENT");
    r.rejected(patched(features_msg(), [](Bytes& p) { st16(p.data() + 6 + 2 * 16, VC_FEATURE_LEFT_HAND); }),
               VC_PROTO_EINCONSISTENT);
  }
  {
    Vector& r = add("bad_feature_state", "A FEATURES with state 7 (undefined): VC_PROTO_EFIELD");
    r.rejected(patched(features_msg(), [](Bytes& p) { st16(p.data() + 6 + 2, 7); }), VC_PROTO_EFIELD);
  }
  {
    Vector& r =
        add("bad_cleanup_radius", "A CONFIG with cleanup_radius_px 9 (the edge runs 0..8): VC_PROTO_EFIELD");
    r.rejected(patched(config_msg(), [](Bytes& p) { st32(p.data() + 60, 9); }), VC_PROTO_EFIELD);
  }
  {
    Vector& r =
        add("bad_carve_rule",
            "A CONFIG with carve_rule 3 (0 centre, 1 footprint, 2 subpixel): VC_PROTO_EFIELD; the HEARTBEAT "
            "after it decodes");
    r.rejected(patched(config_msg(), [](Bytes& p) { st16(p.data() + 64, 3); }), VC_PROTO_EFIELD);
    r.message(heartbeat_msg());
  }
  {
    Vector& r = add("bad_silhouette_scale",
                    "A CONFIG asking for a SILHOUETTE every 4th frame at silhouette_scale 0, then one at "
                    "scale 17 (1..16): VC_PROTO_EFIELD twice");
    r.rejected(patched(config_msg(), [](Bytes& p) { p[67] = 0; }), VC_PROTO_EFIELD);
    r.rejected(patched(config_msg(), [](Bytes& p) { p[67] = 17; }), VC_PROTO_EFIELD);
  }
  {
    Vector& r = add("silhouette_inconsistent",
                    "A SILHOUETTE whose foreground_count is one more than its occupied runs sum to, then "
                    "one whose 20x16 size is not the 300 pixels its runs cover: VC_PROTO_EINCONSISTENT "
                    "twice; the SILHOUETTE after them decodes");
    r.rejected(patched(silhouette_msg(sil),
                       [&](Bytes& p) { st32(p.data() + 12, static_cast<uint32_t>(sil.occupied + 1)); }),
               VC_PROTO_EINCONSISTENT);
    r.rejected(patched(silhouette_msg(sil), [](Bytes& p) { st16(p.data() + 6, kSilH + 1); }),
               VC_PROTO_EINCONSISTENT);
    r.message(silhouette_msg(sil, 0, kSeq + 4, kTrigger + 4 * 16'666'667ull));
  }
  {
    Vector& r = add("silhouette_limits",
                    "SILHOUETTEs with width 16385 (VC_PROTO_ELIMIT), camera 8 (VC_PROTO_EFIELD), scale 0 "
                    "(VC_PROTO_EFIELD) and height 0 (VC_PROTO_EFIELD)");
    r.rejected(
        patched(silhouette_msg(sil), [](Bytes& p) { st16(p.data() + 4, VC_PROTO_MAX_SILHOUETTE_SIDE + 1); }),
        VC_PROTO_ELIMIT);
    r.rejected(patched(silhouette_msg(sil), [](Bytes& p) { st16(p.data() + 0, VC_PROTO_MAX_CAMERAS); }),
               VC_PROTO_EFIELD);
    r.rejected(patched(silhouette_msg(sil), [](Bytes& p) { st16(p.data() + 2, 0); }), VC_PROTO_EFIELD);
    r.rejected(patched(silhouette_msg(sil), [](Bytes& p) { st16(p.data() + 6, 0); }), VC_PROTO_EFIELD);
  }
  {
    Vector& r = add("silhouette_bad_rle",
                    "A SILHOUETTE whose RLE has a zero run in the middle, then one whose rle_len runs past "
                    "the payload: VC_PROTO_ERLE, VC_PROTO_ETRUNCATED");
    r.rejected(patched(silhouette_msg(sil),
                       [](Bytes& p) {
                         p.resize(16);
                         p.insert(p.end(), {0x96, 0x01, 0x00, 0x96, 0x01});  // 150, 0, 150
                         st32(p.data() + 8, 5);
                       }),
               VC_PROTO_ERLE);
    r.rejected(
        patched(silhouette_msg(sil), [](Bytes& p) { st32(p.data() + 8, static_cast<uint32_t>(p.size())); }),
        VC_PROTO_ETRUNCATED);
  }
  {
    Vector& r = add("bad_utf8", "An ERROR whose text is not UTF-8 (0xc3 0x28): VC_PROTO_EFIELD");
    r.rejected(patched(error_msg(), [](Bytes& p) { p[10] = 0xC3, p[11] = 0x28; }), VC_PROTO_EFIELD);
  }
  {
    Vector& r = add("hello_node_mismatch",
                    "A HELLO whose node_id (4) differs from its header's (3): "
                    "VC_PROTO_EINCONSISTENT");
    r.rejected(patched(hello_msg(), [](Bytes& p) { st16(p.data(), 4); }), VC_PROTO_EINCONSISTENT);
  }
  // ---- authenticated control (2.3): the handshake and MAC'd streams, deterministic key and nonces ----
  const AuthInputs ai;
  {
    Vector& a = add("auth",
                    "AUTH handshake of node 3 on a keyed rig (after its HELLO): the node's challenge, the "
                    "host's response (its nonce and proof), the node's proof; key, nonces and proofs in "
                    "`auth` (a proof verifies only for its role)");
    uint8_t proof_host[VC_AUTH_PROOF_SIZE], proof_node[VC_AUTH_PROOF_SIZE];
    vc_auth_prove(proof_host, ai.key, VC_AUTH_ROLE_HOST, kNode, ai.nonce_node, ai.nonce_host);
    vc_auth_prove(proof_node, ai.key, VC_AUTH_ROLE_NODE, kNode, ai.nonce_node, ai.nonce_host);
    a.message(auth_msg(VC_AUTH_CHALLENGE, ai.nonce_node, nullptr));
    a.message(auth_msg(VC_AUTH_RESPONSE, ai.nonce_host, proof_host));
    a.message(auth_msg(VC_AUTH_PROOF, nullptr, proof_node));
    a.auth = ai.json();
    a.auth["proof_host"] = hex(Bytes(proof_host, proof_host + VC_AUTH_PROOF_SIZE));
    a.auth["proof_node"] = hex(Bytes(proof_node, proof_node + VC_AUTH_PROOF_SIZE));
  }
  {
    Vector& m = add("mac_stream",
                    "After the `auth` handshake, node 3's messages sealed with the node-to-host MAC key "
                    "(counters 0..3, `mac`): HEARTBEAT running, HULL, FEATURES, STATS; each decodes with "
                    "its trailer removed");
    vc_mac tx = ai.node_to_host();
    for (const vc_msg& msg : {heartbeat_msg(VC_STATE_RUNNING), hull_msg(small), features_msg(), stats_msg()})
      m.sealed(msg, seal(msg, tx));
    m.mac = ai.mac_json();
  }
  {
    Vector& f = add("mac_forged",
                    "On the `mac` stream: a sealed HULL with one RLE byte changed (CRCs recomputed), the "
                    "HULL sealed with another key, a HEARTBEAT without a MAC: VC_PROTO_EMAC three times, "
                    "the counter unmoved; the real sealed HULL (counter 0) after them decodes");
    vc_mac tx = ai.node_to_host();
    const Bytes real = seal(hull_msg(small), tx);
    Bytes changed = real;
    changed[VC_PROTO_HEADER_SIZE + 24] ^= 0x01;  // the first RLE byte
    f.rejected(recrc(changed), VC_PROTO_EMAC);
    vc_mac other = ai.node_to_host();
    other.key[0] ^= 0x80;
    f.rejected(seal(hull_msg(small), other), VC_PROTO_EMAC);
    f.rejected(encode(heartbeat_msg(VC_STATE_RUNNING)), VC_PROTO_EMAC);
    f.sealed(hull_msg(small), real);
    f.mac = ai.mac_json();
  }
  {
    Vector& r = add("mac_replayed",
                    "On the `mac` stream: a sealed HULL (counter 0), the same bytes again: "
                    "VC_PROTO_EREPLAY; the HEARTBEAT sealed with counter 1 after it decodes");
    vc_mac tx = ai.node_to_host();
    const Bytes hull = seal(hull_msg(small), tx);
    r.sealed(hull_msg(small), hull);
    r.rejected(hull, VC_PROTO_EREPLAY);
    const vc_msg hb = heartbeat_msg(VC_STATE_RUNNING);
    r.sealed(hb, seal(hb, tx));
    r.mac = ai.mac_json();
  }
  {
    Vector& o = add("mac_reordered",
                    "On the `mac` stream: FEATURES sealed with counter 1 before the HULL of counter 0: "
                    "VC_PROTO_EORDER; then the HULL (0) and the same FEATURES (1) decode");
    vc_mac tx = ai.node_to_host();
    const Bytes hull = seal(hull_msg(small), tx);
    const Bytes feats = seal(features_msg(), tx);
    o.rejected(feats, VC_PROTO_EORDER);
    o.sealed(hull_msg(small), hull);
    o.sealed(features_msg(), feats);
    o.mac = ai.mac_json();
  }
  {  // 2.4: GRAB and FRAME
    add("grab", "GRAB to node 3: from frame 1042, every 15th frame, both cameras, gray8, 40 frames")
        .message(grab_msg());
    add("grab_stop", "GRAB with every 0: stop sending FRAMEs").message(grab_msg(0, 0, 0));
    add("frame", "FRAME of frame 1042, camera 1: a 6x4 rgb8 image (72 pixel bytes, rows without padding)")
        .message(frame_msg());
    add("frame_gray", "FRAME of frame 1042, camera 0: the same image as gray8 (24 bytes of BT.601 luma)")
        .message(frame_msg(0, VC_FRAME_GRAY8));
    Vector& r = add("frame_rejections",
                    "FRAMEs rejected, each followed by nothing fatal: pixels_len 71 for a 6x4 rgb8 image "
                    "(VC_PROTO_EINCONSISTENT), 72 announced but 70 sent (VC_PROTO_ETRUNCATED), one byte "
                    "after the pixels (VC_PROTO_ETRAILING), format 3 (VC_PROTO_EFIELD), width 16385 "
                    "(VC_PROTO_ELIMIT), camera 8 (VC_PROTO_EFIELD); a GRAB with format 0 and every 15 "
                    "(VC_PROTO_EFIELD); then a FRAME that decodes");
    r.rejected(patched(frame_msg(), [](Bytes& p) { st32(p.data() + 8, 71); }), VC_PROTO_EINCONSISTENT);
    r.rejected(patched(frame_msg(), [](Bytes& p) { p.resize(p.size() - 2); }), VC_PROTO_ETRUNCATED);
    r.rejected(patched(frame_msg(), [](Bytes& p) { p.push_back(0); }), VC_PROTO_ETRAILING);
    r.rejected(patched(frame_msg(), [](Bytes& p) { st16(p.data() + 2, 3); }), VC_PROTO_EFIELD);
    r.rejected(patched(frame_msg(), [](Bytes& p) { st16(p.data() + 4, 16385); }), VC_PROTO_ELIMIT);
    r.rejected(patched(frame_msg(), [](Bytes& p) { st16(p.data() + 0, 8); }), VC_PROTO_EFIELD);
    r.rejected(patched(grab_msg(), [](Bytes& p) { st16(p.data() + 2, 0); }), VC_PROTO_EFIELD);
    r.message(frame_msg());
  }
  return v;
}

// ---- RLE and trigger vectors -------------------------------------------------------------------------

Json rle_vectors() {
  Json valid = Json::array(), invalid = Json::array();
  auto add = [&](const char* name, size_t nbits, const std::vector<size_t>& set_bits, Bytes dirty_pad = {}) {
    Bytes bits((nbits + 7) / 8, 0);
    for (size_t i : set_bits) bits[i / 8] = static_cast<uint8_t>(bits[i / 8] | (1u << (i % 8)));
    Json e;
    e["name"] = name;
    e["nbits"] = nbits;
    e["bits"] = hex(bits);
    if (!dirty_pad.empty()) {
      Bytes in = bits;
      for (size_t i = 0; i < in.size(); i++) in[i] |= dirty_pad[i];
      e["encode_input"] = hex(in);
    }
    e["occupied"] = set_bits.size();
    e["rle"] = hex(reference_rle(bits, nbits));
    valid.push_back(e);
  };
  auto range = [](size_t a, size_t b) {
    std::vector<size_t> r;
    for (size_t i = a; i < b; i++) r.push_back(i);
    return r;
  };
  add("no_bits", 0, {});
  add("all_empty", 10, {});
  add("all_occupied", 10, range(0, 10));
  add("spec_example", 10, {3, 4, 5});
  add("starts_occupied", 4, {0});
  add("two_byte_run", 300, {});
  std::vector<size_t> alt;
  for (size_t i = 0; i < 9; i += 2) alt.push_back(i);
  add("alternating_worst_case", 9, alt);
  add("three_byte_runs", 40000, range(100, 100 + 20000));
  add("padding_ignored", 13, {0, 12}, Bytes{0x00, 0xE0});
  auto bad = [&](const char* name, const Bytes& rle, size_t nbits, const char* err) {
    Json e;
    e["name"] = name;
    e["nbits"] = nbits;
    e["rle"] = hex(rle);
    e["error"] = err;
    invalid.push_back(e);
  };
  bad("truncated_varint", {0x05, 0x85}, 5, "EBADMSG");
  bad("overlong_varint", {0x85, 0x00, 0x05}, 10, "EBADMSG");
  bad("zero_run_in_the_middle", {0x02, 0x00, 0x03}, 5, "EBADMSG");
  bad("lone_zero_run", {0x00}, 0, "EBADMSG");
  bad("trailing_zero_run", {0x02, 0x03, 0x00}, 5, "EBADMSG");
  bad("varint_over_64_bits", {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x02}, 5, "EBADMSG");
  bad("runs_short_of_nbits", {0x03, 0x03}, 10, "EINVAL");
  bad("runs_past_nbits", {0x03, 0x03, 0x04}, 9, "EINVAL");
  Json j;
  j["description"] = "RLE of hull bitsets (SPEC.md \"RLE\"): bits as hex bytes, LSB first; rle as hex bytes";
  j["valid"] = valid;
  j["invalid"] = invalid;
  return j;
}

void write_file(const std::filesystem::path& p, const std::string& s) {
  std::ofstream f(p, std::ios::binary);
  f.write(s.data(), static_cast<std::streamsize>(s.size()));
  if (!f) throw std::runtime_error("cannot write " + p.string());
}

void write_bytes(const std::filesystem::path& p, const Bytes& b) {
  write_file(p, std::string(b.begin(), b.end()));
}

}  // namespace

std::vector<std::string> write_all(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  std::vector<std::string> names;
  std::string readme =
      "# proto/vectors — generated, do not edit\n\n"
      "Written by `vc_proto_vectors proto/vectors` (proto/tools/); `proto_vectors_test` checks that\n"
      "regenerating gives byte-identical files and that the decoder produces each `.json`'s `events`\n"
      "from the `.bin` fed in any chunking. The fuzz targets start from these files.\n\n"
      "| vector | what it holds, what a receiver must do |\n|---|---|\n";
  if (vc_auth_init() < 0) throw std::runtime_error("libsodium failed to start");
  for (const Vector& v : build_streams()) {
    Json j;
    j["description"] = v.description;
    j["max_payload"] = v.max_payload ? v.max_payload : size_t{VC_PROTO_MAX_PAYLOAD};
    if (!v.mac.is_null()) j["mac"] = v.mac;
    if (!v.auth.is_null()) j["auth"] = v.auth;
    j["events"] = v.events;
    write_bytes(dir / (v.name + ".bin"), v.bytes);
    write_file(dir / (v.name + ".json"), j.dump(2) + "\n");
    names.push_back(v.name + ".bin");
    names.push_back(v.name + ".json");
    readme += fmt::format("| `{}` | {} |\n", v.name, v.description);
  }
  write_file(dir / "rle.json", rle_vectors().dump(2) + "\n");
  names.push_back("rle.json");
  readme += "| `rle.json` | RLE encodings of small bitsets, and malformed RLE with the errno each gives |\n";

  Bytes dgram(VC_TRIGGER_DGRAM_SIZE);
  vc_trigger_dgram_encode(dgram.data(), kSeq, kTrigger);
  write_bytes(dir / "trigger.bin", dgram);
  Json tj;
  tj["description"] = "Trigger datagram of pulse 1042";
  tj["seq"] = kSeq;
  tj["t_ns"] = kTrigger;
  write_file(dir / "trigger.json", tj.dump(2) + "\n");
  Bytes bad = dgram;
  bad[4] = 2;
  write_bytes(dir / "trigger_bad_version.bin", bad);
  Json bj;
  bj["description"] = "Trigger datagram of version 2: rejected";
  bj["error"] = "EBADMSG";
  write_file(dir / "trigger_bad_version.json", bj.dump(2) + "\n");
  names.insert(names.end(),
               {"trigger.bin", "trigger.json", "trigger_bad_version.bin", "trigger_bad_version.json"});
  readme +=
      "| `trigger` | the emulated trigger datagram of pulse 1042 |\n"
      "| `trigger_bad_version` | a trigger datagram of version 2: `-EBADMSG` |\n";
  {  // The authenticated trigger datagram (version 2) with the `auth` vectors' rig key.
    const AuthInputs ai;
    vc_mac tx{};
    vc_auth_trigger_key(ai.key, &tx);
    tx.counter = 7;
    Bytes d(VC_TRIGGER_DGRAM_MAC_SIZE);
    vc_trigger_dgram_encode_mac(d.data(), kSeq, kTrigger, &tx);
    write_bytes(dir / "trigger_mac.bin", d);
    Json mj;
    mj["description"] =
        "Authenticated trigger datagram (version 2) of pulse 1042, counter 7, with the trigger key of "
        "rig_key: accepted by a receiver expecting counter <= 7; the same bytes again are a replay "
        "(VC_PROTO_EREPLAY), any byte changed a forgery (VC_PROTO_EMAC)";
    mj["rig_key"] = hex(Bytes(ai.key, ai.key + VC_AUTH_KEY_SIZE));
    mj["trigger_key"] = hex(Bytes(tx.key, tx.key + VC_AUTH_KEY_SIZE));
    mj["counter"] = 7;
    mj["seq"] = kSeq;
    mj["t_ns"] = kTrigger;
    write_file(dir / "trigger_mac.json", mj.dump(2) + "\n");
    names.insert(names.end(), {"trigger_mac.bin", "trigger_mac.json"});
    readme +=
        "| `trigger_mac` | the authenticated trigger datagram (version 2) of pulse 1042, counter 7, "
        "with the `auth` vectors' rig key: accepted once; replayed: `VC_PROTO_EREPLAY`; any byte "
        "changed: `VC_PROTO_EMAC` |\n";
  }
  write_file(dir / "README.md", readme);
  names.push_back("README.md");
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace vc::proto::vectors
