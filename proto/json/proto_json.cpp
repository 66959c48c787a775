// JSON and text renderings of protocol messages (see proto_json.hpp). Field names are SPEC.md's.
#include "voxcap/proto_json.hpp"

#include <algorithm>
#include <cerrno>
#include <istream>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <vector>

#include <fmt/core.h>

#include "voxcap/rle.h"

namespace vc::proto {
namespace {

std::string hex(const uint8_t* p, size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string s(2 * n, '0');
  for (size_t i = 0; i < n; i++) {
    s[2 * i] = digits[p[i] >> 4];
    s[2 * i + 1] = digits[p[i] & 15];
  }
  return s;
}

// Adds "<key>": hex of bytes (cut to opt.max_hex_bytes, then "<key>_truncated": true).
void put_hex(Json& j, const char* key, const uint8_t* p, size_t n, const JsonOptions& opt) {
  size_t shown = std::min(n, opt.max_hex_bytes);
  j[key] = p ? hex(p, shown) : std::string();
  if (shown < n) j[std::string(key) + "_truncated"] = true;
}

// "<key>_name" next to an enumerated field, when the value has a name.
void put_name(Json& j, const char* key, const char* name) {
  if (name) j[std::string(key) + "_name"] = name;
}

std::string fourcc(uint32_t v) {
  std::string s;
  for (int i = 0; i < 4; i++) {
    char c = static_cast<char>((v >> (8 * i)) & 0xFF);
    if (c < 0x20 || c > 0x7E) return {};
    s += c;
  }
  return s;
}

template <size_t N>
Json array(const double (&v)[N]) {
  Json a = Json::array();
  for (double x : v) a.push_back(x);
  return a;
}

Json hello_json(const vc_hello& m) {
  Json j;
  j["node_id"] = m.node_id;
  j["sw_major"] = m.sw_major;
  j["sw_minor"] = m.sw_minor;
  j["sw_patch"] = m.sw_patch;
  j["capabilities"] = m.capabilities;
  Json caps = Json::array();
  const char* cap_names[] = {"hull", "features", "gpio_trigger", "udp_trigger"};
  for (unsigned b = 0; b < 4; b++)
    if (m.capabilities & (1u << b)) caps.push_back(cap_names[b]);
  j["capabilities_names"] = caps;
  j["camera_count"] = m.camera_count;
  j["camera_record_size"] = m.camera_record_size;
  Json cams = Json::array();
  for (unsigned i = 0; i < m.camera_count && i < VC_PROTO_MAX_CAMERAS; i++) {
    const vc_hello_camera& c = m.cameras[i];
    Json cj;
    cj["width"] = c.width;
    cj["height"] = c.height;
    cj["pixel_format"] = c.pixel_format;
    if (auto s = fourcc(c.pixel_format); !s.empty()) cj["pixel_format_name"] = s;
    cj["max_fps_milli"] = c.max_fps_milli;
    cams.push_back(cj);
  }
  j["cameras"] = cams;
  return j;
}

Json config_json(const vc_config& m) {
  Json j;
  j["grid_id"] = m.grid_id;
  j["nx"] = m.grid.nx;
  j["ny"] = m.grid.ny;
  j["nz"] = m.grid.nz;
  j["min_m"] = array(m.grid.min_m);
  j["voxel_m"] = m.grid.voxel_m;
  j["t_upper"] = m.t_upper;
  j["t_lower"] = m.t_lower;
  j["shadow_angle_deg"] = m.shadow_angle_deg;
  j["cleanup_radius_px"] = m.cleanup_radius_px;
  j["carve_rule"] = m.carve_rule;
  put_name(j, "carve_rule", vc_carve_rule_name(m.carve_rule));
  j["silhouette_every"] = m.silhouette_every;
  j["silhouette_scale"] = m.silhouette_scale;
  j["background_frames"] = m.background_frames;
  j["feature_role"] = m.feature_role;
  put_name(j, "feature_role", vc_role_name(m.feature_role));
  j["camera_count"] = m.camera_count;
  j["camera_record_size"] = m.camera_record_size;
  Json cams = Json::array();
  for (unsigned i = 0; i < m.camera_count && i < VC_PROTO_MAX_CAMERAS; i++) {
    const vc_camera& c = m.cameras[i];
    Json cj;
    cj["width"] = c.width;
    cj["height"] = c.height;
    cj["K"] = array(c.K);
    cj["dist"] = array(c.dist);
    cj["R_cam_from_world"] = array(c.R_cam_from_world);
    cj["t_cam_from_world"] = array(c.t_cam_from_world);
    cams.push_back(cj);
  }
  j["cameras"] = cams;
  return j;
}

// The first max_runs runs of a validated RLE stream (a plain LEB128 walk, bounded by len and 64-bit
// values anyway); sets runs_truncated when there are more than it shows.
void put_runs(Json& j, const uint8_t* rle, uint32_t len, uint64_t run_count, const JsonOptions& opt) {
  if (opt.max_runs == 0 || !rle) return;
  Json runs = Json::array();
  const uint8_t* p = rle;
  const uint8_t* end = rle + len;
  while (p < end && runs.size() < opt.max_runs) {
    uint64_t v = 0;
    for (unsigned shift = 0; p < end && shift < 64; shift += 7) {
      uint8_t b = *p++;
      v |= static_cast<uint64_t>(b & 0x7F) << shift;
      if (!(b & 0x80)) break;
    }
    runs.push_back(v);
  }
  j["runs"] = runs;
  if (runs.size() < run_count) j["runs_truncated"] = true;
}

Json auth_json(const vc_auth_msg& m) {
  static const char* const steps[] = {nullptr, "challenge", "response", "proof"};
  Json j;
  j["step"] = m.step;
  if (m.step < 4) j["step_name"] = steps[m.step];
  j["nonce"] = hex(m.nonce, sizeof m.nonce);
  j["proof"] = hex(m.proof, sizeof m.proof);
  return j;
}

Json silhouette_json(const vc_silhouette& m, const JsonOptions& opt) {
  Json j;
  j["camera"] = m.camera;
  j["scale"] = m.scale;
  j["width"] = m.width;
  j["height"] = m.height;
  j["rle_len"] = m.rle_len;
  j["foreground_count"] = m.foreground_count;
  j["run_count"] = m.run_count;
  put_hex(j, "rle", m.rle, m.rle_len, opt);
  put_runs(j, m.rle, m.rle_len, m.run_count, opt);
  return j;
}

Json grab_json(const vc_grab& m) {
  Json j;
  j["every"] = m.every;
  j["format"] = m.format;
  put_name(j, "format", vc_frame_format_name(m.format));
  j["cameras"] = m.cameras;
  j["count"] = m.count;
  return j;
}

Json frame_json(const vc_frame_msg& m, const JsonOptions& opt) {
  Json j;
  j["camera"] = m.camera;
  j["format"] = m.format;
  put_name(j, "format", vc_frame_format_name(m.format));
  j["width"] = m.width;
  j["height"] = m.height;
  j["pixels_len"] = m.pixels_len;
  put_hex(j, "pixels", m.pixels, m.pixels_len, opt);
  return j;
}

Json hull_json(const vc_hull& m, const JsonOptions& opt) {
  Json j;
  j["grid_id"] = m.grid_id;
  j["rle_len"] = m.rle_len;
  j["voxel_count"] = m.voxel_count;
  j["occupied_count"] = m.occupied_count;
  j["run_count"] = m.run_count;
  put_hex(j, "rle", m.rle, m.rle_len, opt);
  put_runs(j, m.rle, m.rle_len, m.run_count, opt);
  return j;
}

Json features_json(const vc_features& m) {
  Json j;
  j["camera"] = m.camera;
  j["feature_count"] = m.feature_count;
  j["feature_record_size"] = m.feature_record_size;
  Json fs = Json::array();
  for (unsigned i = 0; i < m.feature_count && i < VC_PROTO_MAX_FEATURES; i++) {
    const vc_feature& f = m.features[i];
    Json fj;
    fj["feature_id"] = f.feature_id;
    put_name(fj, "feature_id", vc_feature_name(f.feature_id));
    fj["state"] = f.state;
    put_name(fj, "state", vc_feature_state_name(f.state));
    fj["u"] = f.u;
    fj["v"] = f.v;
    fj["confidence"] = f.confidence;
    fs.push_back(fj);
  }
  j["features"] = fs;
  return j;
}

Json stats_json(const vc_stats& m) {
  Json j;
  j["frames"] = m.frames;
  j["stage_count"] = m.stage_count;
  j["counter_count"] = m.counter_count;
  Json stages = Json::array(), counters = Json::array();
  for (unsigned i = 0; i < m.stage_count && i < VC_PROTO_MAX_STAGES; i++) {
    Json s;
    s["stage_id"] = m.stages[i].stage_id;
    put_name(s, "stage_id", vc_stage_name(m.stages[i].stage_id));
    s["mean_ns"] = m.stages[i].mean_ns;
    s["max_ns"] = m.stages[i].max_ns;
    stages.push_back(s);
  }
  for (unsigned i = 0; i < m.counter_count && i < VC_PROTO_MAX_COUNTERS; i++) {
    Json c;
    c["counter_id"] = m.counters[i].counter_id;
    put_name(c, "counter_id", vc_counter_name(m.counters[i].counter_id));
    c["value"] = m.counters[i].value;
    counters.push_back(c);
  }
  j["stages"] = stages;
  j["counters"] = counters;
  return j;
}

Json error_body_json(const vc_error& m) {
  Json j;
  j["code"] = m.code;
  put_name(j, "code", vc_error_code_name(m.code));
  j["severity"] = m.severity;
  put_name(j, "severity", vc_error_severity_name(m.severity));
  j["about_type"] = m.about_type;
  put_name(j, "about_type", vc_msg_type_name(m.about_type));
  j["text_len"] = m.text_len;
  j["text"] = m.text ? std::string(m.text, m.text_len) : std::string();
  return j;
}

Json type_json(uint16_t type) {
  const char* name = vc_msg_type_name(type);
  return name ? Json(name) : Json(type);
}

}  // namespace

Json header_to_json(const vc_header& h) {
  Json j;
  j["magic"] = VC_PROTO_MAGIC;  // every decoded message has it; shown so the dump lists every header field
  j["version_major"] = h.version_major;
  j["version_minor"] = h.version_minor;
  j["type"] = h.type;
  j["flags"] = h.flags;
  j["node_id"] = h.node_id;
  j["payload_len"] = h.payload_len;
  j["seq"] = h.seq;
  j["t_trigger_ns"] = h.t_trigger_ns;
  j["payload_crc"] = h.payload_crc;
  j["header_crc"] = h.header_crc;
  return j;
}

Json msg_to_json(const vc_msg& msg, const JsonOptions& opt) {
  Json j;
  const char* name = vc_msg_type_name(msg.hdr.type);
  j["type"] = name && msg.known ? name : "UNKNOWN";
  j["header"] = header_to_json(msg.hdr);
  j["known"] = msg.known;
  j["ignored_bytes"] = msg.ignored_bytes;
  Json body = Json::object();
  if (!msg.known) {
    put_hex(body, "payload", msg.payload, msg.payload ? msg.hdr.payload_len : 0, opt);
  } else {
    switch (msg.hdr.type) {
      case VC_MSG_HELLO:
        body = hello_json(msg.u.hello);
        break;
      case VC_MSG_CONFIG:
        body = config_json(msg.u.config);
        break;
      case VC_MSG_BACKGROUND:
        body["frame_count"] = msg.u.background.frame_count;
        break;
      case VC_MSG_HULL:
        body = hull_json(msg.u.hull, opt);
        break;
      case VC_MSG_FEATURES:
        body = features_json(msg.u.features);
        break;
      case VC_MSG_STATS:
        body = stats_json(msg.u.stats);
        break;
      case VC_MSG_HEARTBEAT:
        body["sender_time_ns"] = msg.u.heartbeat.sender_time_ns;
        body["state"] = msg.u.heartbeat.state;
        put_name(body, "state", vc_node_state_name(msg.u.heartbeat.state));
        break;
      case VC_MSG_ERROR:
        body = error_body_json(msg.u.error);
        break;
      case VC_MSG_SILHOUETTE:
        body = silhouette_json(msg.u.silhouette, opt);
        break;
      case VC_MSG_AUTH:
        body = auth_json(msg.u.auth);
        break;
      case VC_MSG_GRAB:
        body = grab_json(msg.u.grab);
        break;
      case VC_MSG_FRAME:
        body = frame_json(msg.u.frame, opt);
        break;
      default:
        break;  // START, STOP: no fields
    }
  }
  j["body"] = body;
  return j;
}

Json error_to_json(const vc_proto_diag& diag, bool with_detail) {
  Json j;
  j["code"] = vc_proto_error_name(diag.code);
  j["value"] = diag.code;
  j["fatal"] = vc_proto_error_is_fatal(diag.code);
  j["message"] = vc_proto_strerror(diag.code);
  if (with_detail) j["detail"] = diag.detail;
  return j;
}

namespace {

struct DecoderDeleter {
  void operator()(vc_decoder* d) const { vc_decoder_free(d); }
};
using DecoderPtr = std::unique_ptr<vc_decoder, DecoderDeleter>;

DecoderPtr make_decoder(size_t max_payload) {
  vc_decoder* dec = nullptr;
  char why[128];
  if (vc_decoder_new(max_payload, &dec, why, sizeof why) < 0) throw std::runtime_error(why);
  return DecoderPtr(dec);
}

// Drains every message the decoder can produce now into `sink`; false after a fatal error.
template <typename Sink>
bool drain(vc_decoder* dec, Sink&& sink) {
  auto msg = std::make_unique<vc_msg>();
  for (;;) {
    uint64_t offset = vc_decoder_offset(dec);
    int rc = vc_decoder_next(dec, msg.get());
    if (rc == 0) return true;
    sink(rc, offset, *msg);
    if (rc < 0 && vc_proto_error_is_fatal(rc)) return false;
  }
}

}  // namespace

Json decode_events(std::span<const uint8_t> bytes, size_t max_payload,
                   const std::function<size_t(size_t)>& chunker, bool with_detail, const JsonOptions& opt) {
  DecoderPtr dec = make_decoder(max_payload);
  Json events = Json::array();
  auto sink = [&](int rc, uint64_t offset, const vc_msg& msg) {
    Json e;
    e["offset"] = offset;
    if (rc > 0) {
      e["message"] = msg_to_json(msg, opt);
    } else {
      e["error"] = error_to_json(*vc_decoder_diag(dec.get()), with_detail);
      if (!vc_proto_error_is_fatal(rc)) e["type"] = type_json(msg.hdr.type);
    }
    events.push_back(e);
  };
  size_t pos = 0;
  while (pos < bytes.size()) {
    size_t left = bytes.size() - pos;
    size_t chunk = chunker ? std::clamp<size_t>(chunker(left), 1, left) : left;
    size_t off = 0;
    while (off < chunk) {
      size_t used = 0;
      int rc = vc_decoder_feed(dec.get(), bytes.data() + pos + off, chunk - off, &used);
      if (rc == -ENOMEM) throw std::bad_alloc();
      if (rc < 0) return events;  // the sticky fatal error, already an event
      off += used;
      if (!drain(dec.get(), sink)) return events;
    }
    pos += chunk;
  }
  if (vc_decoder_finish(dec.get()) < 0) {
    Json e;
    e["offset"] = vc_decoder_diag(dec.get())->offset;
    e["error"] = error_to_json(*vc_decoder_diag(dec.get()), with_detail);
    events.push_back(e);
  }
  return events;
}

bool DumpOptions::valid(std::string* why) const {
  if (max_payload > VC_PROTO_MAX_PAYLOAD) {
    if (why)
      *why = fmt::format("max_payload {} is over the protocol limit {}", max_payload, VC_PROTO_MAX_PAYLOAD);
    return false;
  }
  return true;
}

namespace {

std::string scalar_text(const Json& v) {
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

// Fields clearer in hex: the magic, flags and CRCs.
bool shown_in_hex(const std::string& key) {
  return key == "magic" || key == "flags" || key.ends_with("_crc");
}

// "k=v k=v" for a flat object (nested arrays printed as JSON).
std::string inline_object(const Json& o) {
  std::string s;
  for (const auto& [k, v] : o.items()) {
    if (!s.empty()) s += ' ';
    if (v.is_number_unsigned() && shown_in_hex(k))
      s += fmt::format("{}=0x{:0{}x}", k, v.get<uint64_t>(), k == "flags" ? 4 : 8);
    else
      s += k + '=' + scalar_text(v);
  }
  return s;
}

}  // namespace

std::string event_to_text(const Json& event) {
  std::string out;
  const uint64_t offset = event.value("offset", uint64_t{0});
  if (event.contains("error")) {
    const Json& e = event["error"];
    out += fmt::format("@{} {} {}: {}", offset, e["fatal"].get<bool>() ? "FATAL" : "REJECTED",
                       e["code"].get<std::string>(), e["message"].get<std::string>());
    if (event.contains("type")) out += fmt::format(" (message type {})", scalar_text(event["type"]));
    if (e.contains("detail") && !e["detail"].get<std::string>().empty())
      out += fmt::format("\n  detail: {}", e["detail"].get<std::string>());
    return out + '\n';
  }
  const Json& m = event["message"];
  out += fmt::format("@{} {}\n", offset, m["type"].get<std::string>());
  out += "  header: " + inline_object(m["header"]) + '\n';
  if (!m["known"].get<bool>()) out += "  known: false (type not defined in this version; skipped)\n";
  if (m["ignored_bytes"].get<uint64_t>() > 0)
    out += fmt::format("  ignored_bytes: {} (fields of a newer minor version)\n",
                       m["ignored_bytes"].get<uint64_t>());
  for (const auto& [k, v] : m["body"].items()) {
    if (v.is_array() && !v.empty() && v[0].is_object()) {
      for (size_t i = 0; i < v.size(); i++) out += fmt::format("  {}[{}]: {}\n", k, i, inline_object(v[i]));
    } else {
      out += fmt::format("  {}: {}\n", k, scalar_text(v));
    }
  }
  return out;
}

DumpResult dump(std::istream& in, std::ostream& out, const DumpOptions& opt) {
  std::string why;
  if (!opt.valid(&why)) throw std::invalid_argument(why);
  DecoderPtr dec = make_decoder(opt.max_payload);
  DumpResult result;
  auto emit = [&](const Json& event) {
    if (opt.json)
      out << event.dump() << '\n';
    else
      out << event_to_text(event);
  };
  auto sink = [&](int rc, uint64_t offset, const vc_msg& msg) {
    Json e;
    e["offset"] = offset;
    if (rc > 0) {
      e["message"] = msg_to_json(msg, opt.fields);
      result.messages++;
    } else {
      const vc_proto_diag* d = vc_decoder_diag(dec.get());
      e["error"] = error_to_json(*d, true);
      if (vc_proto_error_is_fatal(rc)) {
        result.fatal = rc;
        result.fatal_offset = d->offset;
        result.fatal_detail = d->detail;
      } else {
        e["type"] = type_json(msg.hdr.type);
        result.rejected++;
      }
    }
    emit(e);
  };
  std::vector<uint8_t> chunk(64 * 1024);
  while (in) {
    in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(chunk.size()));
    size_t n = static_cast<size_t>(in.gcount());
    if (n == 0) break;
    for (size_t off = 0; off < n;) {
      size_t used = 0;
      int rc = vc_decoder_feed(dec.get(), chunk.data() + off, n - off, &used);
      if (rc == -ENOMEM) throw std::bad_alloc();
      if (rc < 0) return result;  // the sticky fatal error, already reported
      off += used;
      if (!drain(dec.get(), sink)) return result;
    }
  }
  if (in.bad()) throw std::runtime_error("read error");
  if (vc_decoder_finish(dec.get()) < 0) {
    const vc_proto_diag* d = vc_decoder_diag(dec.get());
    Json e;
    e["offset"] = d->offset;
    e["error"] = error_to_json(*d, true);
    result.fatal = d->code;
    result.fatal_offset = d->offset;
    result.fatal_detail = d->detail;
    emit(e);
  }
  return result;
}

}  // namespace vc::proto
