/* Names of codes and enumerations, as SPEC.md spells them (used by tools, dumps and test vectors). */
#include <errno.h>

#include "internal.h"

#define ARRAY_LEN(a) (sizeof(a) / sizeof((a)[0]))

static const char* lookup(const char* const* names, size_t n, uint32_t id) {
  return id < n ? names[id] : NULL;
}

const char* vc_proto_strerror(int code) {
  switch (code) {
    case 0:
      return "success";
    case VC_PROTO_EMAGIC:
      return "bad magic";
    case VC_PROTO_EVERSION:
      return "unsupported protocol major version";
    case VC_PROTO_EHEADER_CRC:
      return "header CRC mismatch";
    case VC_PROTO_EPAYLOAD_CRC:
      return "payload CRC mismatch";
    case VC_PROTO_EOVERSIZE:
      return "payload larger than the receiver's limit";
    case VC_PROTO_EEOF:
      return "stream ended inside a message";
    case VC_PROTO_ETRUNCATED:
      return "payload shorter than its fields";
    case VC_PROTO_ETRAILING:
      return "unexpected bytes after the last field";
    case VC_PROTO_EINCONSISTENT:
      return "inconsistent counts";
    case VC_PROTO_ERLE:
      return "malformed RLE";
    case VC_PROTO_ELIMIT:
      return "count over a protocol limit";
    case VC_PROTO_EFIELD:
      return "field value out of range";
    case VC_PROTO_EMAC:
      return "missing or wrong MAC (forged)";
    case VC_PROTO_EREPLAY:
      return "MAC counter already used (replayed)";
    case VC_PROTO_EORDER:
      return "MAC counter ahead of the next (reordered)";
    case -EINVAL:
      return "invalid argument";
    case -ENOSPC:
      return "output buffer too small";
    case -ENOMEM:
      return "out of memory";
    case -EBADMSG:
      return "malformed data";
    default:
      return "unknown error";
  }
}

const char* vc_proto_error_name(int code) {
  switch (code) {
    case 0:
      return "OK";
    case VC_PROTO_EMAGIC:
      return "VC_PROTO_EMAGIC";
    case VC_PROTO_EVERSION:
      return "VC_PROTO_EVERSION";
    case VC_PROTO_EHEADER_CRC:
      return "VC_PROTO_EHEADER_CRC";
    case VC_PROTO_EPAYLOAD_CRC:
      return "VC_PROTO_EPAYLOAD_CRC";
    case VC_PROTO_EOVERSIZE:
      return "VC_PROTO_EOVERSIZE";
    case VC_PROTO_EEOF:
      return "VC_PROTO_EEOF";
    case VC_PROTO_ETRUNCATED:
      return "VC_PROTO_ETRUNCATED";
    case VC_PROTO_ETRAILING:
      return "VC_PROTO_ETRAILING";
    case VC_PROTO_EINCONSISTENT:
      return "VC_PROTO_EINCONSISTENT";
    case VC_PROTO_ERLE:
      return "VC_PROTO_ERLE";
    case VC_PROTO_ELIMIT:
      return "VC_PROTO_ELIMIT";
    case VC_PROTO_EFIELD:
      return "VC_PROTO_EFIELD";
    case VC_PROTO_EMAC:
      return "VC_PROTO_EMAC";
    case VC_PROTO_EREPLAY:
      return "VC_PROTO_EREPLAY";
    case VC_PROTO_EORDER:
      return "VC_PROTO_EORDER";
    case -EINVAL:
      return "EINVAL";
    case -ENOSPC:
      return "ENOSPC";
    case -ENOMEM:
      return "ENOMEM";
    case -EBADMSG:
      return "EBADMSG";
    default:
      return "UNKNOWN";
  }
}

bool vc_proto_error_is_fatal(int code) {
  switch (code) {
    case VC_PROTO_EMAGIC:
    case VC_PROTO_EVERSION:
    case VC_PROTO_EHEADER_CRC:
    case VC_PROTO_EPAYLOAD_CRC:
    case VC_PROTO_EOVERSIZE:
    case VC_PROTO_EEOF:
      return true;
    default:
      return false;
  }
}

const char* vc_msg_type_name(uint16_t type) {
  static const char* const names[] = {NULL,    "HELLO",      "CONFIG",   "BACKGROUND", "START",
                                      "STOP",  "HULL",       "FEATURES", "STATS",      "HEARTBEAT",
                                      "ERROR", "SILHOUETTE", "AUTH",     "GRAB",       "FRAME"};
  return lookup(names, ARRAY_LEN(names), type);
}

const char* vc_stage_name(uint32_t id) {
  static const char* const names[] = {"capture", "subtract", "cleanup", "carve",
                                      "encode",  "features", "send",    "frame"};
  return lookup(names, ARRAY_LEN(names), id);
}

const char* vc_counter_name(uint32_t id) {
  static const char* const names[] = {"frames_captured",     "hulls_sent",           "features_sent",
                                      "send_queue_drops",    "frames_without_pulse", "pulses_without_frame",
                                      "hulls_over_limit",    "camera_errors",        "silhouettes_sent",
                                      "silhouettes_dropped", "frames_sent",          "frames_dropped"};
  return lookup(names, ARRAY_LEN(names), id);
}

const char* vc_feature_name(uint32_t id) {
  static const char* const names[] = {"head", "left_hand", "right_hand", "left_foot", "right_foot"};
  return lookup(names, ARRAY_LEN(names), id);
}

const char* vc_feature_state_name(uint32_t state) {
  static const char* const names[] = {"tracking", "predicted", "lost", "not_visible"};
  return lookup(names, ARRAY_LEN(names), state);
}

const char* vc_node_state_name(uint32_t state) {
  static const char* const names[] = {"host", "idle", "configured", "background", "ready", "running"};
  return lookup(names, ARRAY_LEN(names), state);
}

const char* vc_role_name(uint32_t role) {
  static const char* const names[] = {"none", "front"};
  return lookup(names, ARRAY_LEN(names), role);
}

const char* vc_carve_rule_name(uint32_t rule) {
  static const char* const names[] = {"centre", "footprint", "subpixel"}; /* vc_carve_rule */
  return lookup(names, ARRAY_LEN(names), rule);
}

const char* vc_error_code_name(uint32_t code) {
  static const char* const names[] = {NULL,     "protocol", "version",  "state",    "config",
                                      "camera", "trigger",  "overload", "internal", "auth"};
  return lookup(names, ARRAY_LEN(names), code);
}

const char* vc_error_severity_name(uint32_t severity) {
  static const char* const names[] = {"warning", "error", "fatal"};
  return lookup(names, ARRAY_LEN(names), severity);
}

const char* vc_frame_format_name(uint32_t format) {
  static const char* const names[] = {NULL, "gray8", "rgb8"}; /* vc_frame_format */
  return lookup(names, ARRAY_LEN(names), format);
}

unsigned vc_frame_format_channels(uint32_t format) {
  switch (format) {
    case VC_FRAME_GRAY8:
      return 1;
    case VC_FRAME_RGB8:
      return 3;
    default:
      return 0;
  }
}
