/* Decoding one message from a buffer (SPEC.md "Framing", "Messages", "Evolution").
 *
 * Order of checks, each before anything that depends on it: magic (as soon as its first bytes are
 * there), version_major, header CRC (so payload_len can be trusted), payload_len against the limit,
 * payload CRC, then the payload of a known type field by field — every read is preceded by a length
 * check, so no input makes it read outside buf[0..len). A newer minor version may append fields at
 * the end of a payload or of a record; those bytes are counted in ignored_bytes and skipped. The
 * same message at this library's minor version must have exactly the documented size. */
#include <errno.h>
#include <string.h>

#include "internal.h"
#include "voxcap/auth.h"
#include "voxcap/crc32c.h"
#include "wire.h"

typedef struct reader {
  const uint8_t* p;
  size_t len, off;
  const char* type; /* message type name for details */
  bool newer;       /* the message's minor version is newer than ours */
  uint32_t ignored;
  vc_proto_diag* diag;
} reader;

static int need(reader* r, size_t n, const char* what) {
  if (r->len - r->off < n)
    return vc_diag_set(r->diag, VC_PROTO_ETRUNCATED,
                       "%s: %s needs %zu bytes at payload offset %zu, payload_len is %zu", r->type, what, n,
                       r->off, r->len);
  return 0;
}

/* A record of `size` bytes of which this version knows `known`. */
static int check_record_size(reader* r, uint16_t size, size_t known, const char* what) {
  if (size < known || (size > known && !r->newer))
    return vc_diag_set(r->diag, VC_PROTO_EINCONSISTENT, "%s: %s is %u, version %d.%d defines %zu", r->type,
                       what, size, VC_PROTO_VERSION_MAJOR, VC_PROTO_VERSION_MINOR, known);
  return 0;
}

/* After the last known field: nothing may follow unless the message is from a newer minor version. */
static int finish(reader* r) {
  size_t rest = r->len - r->off;
  if (rest && !r->newer)
    return vc_diag_set(r->diag, VC_PROTO_ETRAILING, "%s: %zu bytes after the last field (payload_len %zu)",
                       r->type, rest, r->len);
  r->ignored += (uint32_t)rest;
  return 0;
}

static int parse_hello(reader* r, vc_hello* m, uint16_t header_node_id) {
  int rc = need(r, VC_HELLO_FIXED, "the fixed part");
  if (rc) return rc;
  const uint8_t* p = r->p;
  m->node_id = vc_ld16(p + 0);
  m->sw_major = vc_ld16(p + 2);
  m->sw_minor = vc_ld16(p + 4);
  m->sw_patch = vc_ld16(p + 6);
  m->capabilities = vc_ld32(p + 8);
  m->camera_count = vc_ld16(p + 12);
  uint16_t rec = m->camera_record_size = vc_ld16(p + 14);
  r->off = VC_HELLO_FIXED;
  if (m->camera_count > VC_PROTO_MAX_CAMERAS)
    return vc_diag_set(r->diag, VC_PROTO_ELIMIT, "HELLO: camera_count %u > %d", m->camera_count,
                       VC_PROTO_MAX_CAMERAS);
  if ((rc = check_record_size(r, rec, VC_HELLO_CAMERA_SIZE, "camera_record_size"))) return rc;
  if ((rc = need(r, (size_t)m->camera_count * rec, "cameras"))) return rc;
  for (unsigned i = 0; i < m->camera_count; i++) {
    const uint8_t* c = r->p + r->off;
    m->cameras[i].width = vc_ld16(c + 0);
    m->cameras[i].height = vc_ld16(c + 2);
    m->cameras[i].pixel_format = vc_ld32(c + 4);
    m->cameras[i].max_fps_milli = vc_ld32(c + 8);
    r->off += rec;
    r->ignored += rec - VC_HELLO_CAMERA_SIZE;
  }
  if ((rc = finish(r))) return rc;
  return vc_check_hello(m, header_node_id, r->diag);
}

static int parse_config(reader* r, vc_config* m) {
  int rc = need(r, VC_CONFIG_FIXED, "the fixed part");
  if (rc) return rc;
  const uint8_t* p = r->p;
  m->grid_id = vc_ld32(p + 0);
  m->grid.nx = vc_ld32(p + 4);
  m->grid.ny = vc_ld32(p + 8);
  m->grid.nz = vc_ld32(p + 12);
  for (int i = 0; i < 3; i++) m->grid.min_m[i] = vc_ldf64(p + 16 + 8 * i);
  m->grid.voxel_m = vc_ldf64(p + 40);
  m->t_upper = vc_ldf32(p + 48);
  m->t_lower = vc_ldf32(p + 52);
  m->shadow_angle_deg = vc_ldf32(p + 56);
  m->cleanup_radius_px = vc_ld32(p + 60);
  m->carve_rule = vc_ld16(p + 64);
  m->silhouette_every = p[66];
  m->silhouette_scale = p[67];
  m->background_frames = vc_ld32(p + 68);
  m->feature_role = vc_ld16(p + 72);
  m->camera_count = vc_ld16(p + 74);
  uint16_t rec = m->camera_record_size = vc_ld16(p + 76);
  r->off = VC_CONFIG_FIXED;
  if (m->camera_count > VC_PROTO_MAX_CAMERAS)
    return vc_diag_set(r->diag, VC_PROTO_ELIMIT, "CONFIG: camera_count %u > %d", m->camera_count,
                       VC_PROTO_MAX_CAMERAS);
  if ((rc = check_record_size(r, rec, VC_CONFIG_CAMERA_SIZE, "camera_record_size"))) return rc;
  if ((rc = need(r, (size_t)m->camera_count * rec, "cameras"))) return rc;
  for (unsigned i = 0; i < m->camera_count; i++) {
    const uint8_t* c = r->p + r->off;
    vc_camera* cam = &m->cameras[i];
    cam->width = vc_ld32(c + 0);
    cam->height = vc_ld32(c + 4);
    for (int k = 0; k < 9; k++) cam->K[k] = vc_ldf64(c + 8 + 8 * k);
    for (int k = 0; k < 5; k++) cam->dist[k] = vc_ldf64(c + 80 + 8 * k);
    for (int k = 0; k < 9; k++) cam->R_cam_from_world[k] = vc_ldf64(c + 120 + 8 * k);
    for (int k = 0; k < 3; k++) cam->t_cam_from_world[k] = vc_ldf64(c + 192 + 8 * k);
    r->off += rec;
    r->ignored += rec - VC_CONFIG_CAMERA_SIZE;
  }
  if ((rc = finish(r))) return rc;
  return vc_check_config(m, r->diag);
}

static int parse_background(reader* r, vc_background* m) {
  int rc = need(r, VC_BACKGROUND_SIZE, "frame_count");
  if (rc) return rc;
  m->frame_count = vc_ld32(r->p);
  r->off = VC_BACKGROUND_SIZE;
  return finish(r);
}

static int parse_hull(reader* r, vc_hull* m) {
  int rc = need(r, VC_HULL_FIXED, "the fixed part");
  if (rc) return rc;
  const uint8_t* p = r->p;
  m->grid_id = vc_ld32(p + 0);
  m->rle_len = vc_ld32(p + 4);
  m->voxel_count = vc_ld64(p + 8);
  m->occupied_count = vc_ld64(p + 16);
  r->off = VC_HULL_FIXED;
  if ((rc = need(r, m->rle_len, "rle (rle_len)"))) return rc;
  m->rle = p + VC_HULL_FIXED;
  r->off += m->rle_len;
  if ((rc = finish(r))) return rc;
  return vc_check_hull(m, &m->run_count, r->diag);
}

static int parse_features(reader* r, vc_features* m) {
  int rc = need(r, VC_FEATURES_FIXED, "the fixed part");
  if (rc) return rc;
  m->camera = vc_ld16(r->p + 0);
  m->feature_count = vc_ld16(r->p + 2);
  uint16_t rec = m->feature_record_size = vc_ld16(r->p + 4);
  r->off = VC_FEATURES_FIXED;
  if (m->feature_count > VC_PROTO_MAX_FEATURES)
    return vc_diag_set(r->diag, VC_PROTO_ELIMIT, "FEATURES: feature_count %u > %d", m->feature_count,
                       VC_PROTO_MAX_FEATURES);
  if ((rc = check_record_size(r, rec, VC_FEATURE_SIZE, "feature_record_size"))) return rc;
  if ((rc = need(r, (size_t)m->feature_count * rec, "features"))) return rc;
  for (unsigned i = 0; i < m->feature_count; i++) {
    const uint8_t* f = r->p + r->off;
    m->features[i].feature_id = vc_ld16(f + 0);
    m->features[i].state = vc_ld16(f + 2);
    m->features[i].u = vc_ldf32(f + 4);
    m->features[i].v = vc_ldf32(f + 8);
    m->features[i].confidence = vc_ldf32(f + 12);
    r->off += rec;
    r->ignored += rec - VC_FEATURE_SIZE;
  }
  if ((rc = finish(r))) return rc;
  return vc_check_features(m, r->diag);
}

static int parse_stats(reader* r, vc_stats* m) {
  int rc = need(r, VC_STATS_FIXED, "the fixed part");
  if (rc) return rc;
  m->frames = vc_ld32(r->p + 0);
  m->stage_count = vc_ld16(r->p + 4);
  m->counter_count = vc_ld16(r->p + 6);
  r->off = VC_STATS_FIXED;
  if (m->stage_count > VC_PROTO_MAX_STAGES || m->counter_count > VC_PROTO_MAX_COUNTERS)
    return vc_diag_set(r->diag, VC_PROTO_ELIMIT, "STATS: stage_count %u / counter_count %u over %d / %d",
                       m->stage_count, m->counter_count, VC_PROTO_MAX_STAGES, VC_PROTO_MAX_COUNTERS);
  if ((rc = need(r, (size_t)m->stage_count * VC_STAGE_SIZE + (size_t)m->counter_count * VC_COUNTER_SIZE,
                 "stages and counters")))
    return rc;
  for (unsigned i = 0; i < m->stage_count; i++, r->off += VC_STAGE_SIZE) {
    const uint8_t* s = r->p + r->off;
    m->stages[i].stage_id = vc_ld32(s + 0);
    m->stages[i].mean_ns = vc_ld32(s + 4);
    m->stages[i].max_ns = vc_ld32(s + 8);
  }
  for (unsigned i = 0; i < m->counter_count; i++, r->off += VC_COUNTER_SIZE) {
    const uint8_t* c = r->p + r->off;
    m->counters[i].counter_id = vc_ld32(c + 0);
    m->counters[i].value = vc_ld64(c + 4);
  }
  if ((rc = finish(r))) return rc;
  return vc_check_stats(m, r->diag);
}

static int parse_heartbeat(reader* r, vc_heartbeat* m) {
  int rc = need(r, VC_HEARTBEAT_SIZE, "the fixed part");
  if (rc) return rc;
  m->sender_time_ns = vc_ld64(r->p + 0);
  m->state = vc_ld32(r->p + 8);
  r->off = VC_HEARTBEAT_SIZE;
  if ((rc = finish(r))) return rc;
  return vc_check_heartbeat(m, r->diag);
}

static int parse_error(reader* r, vc_error* m) {
  int rc = need(r, VC_ERROR_FIXED, "the fixed part");
  if (rc) return rc;
  m->code = vc_ld32(r->p + 0);
  m->severity = vc_ld16(r->p + 4);
  m->about_type = vc_ld16(r->p + 6);
  m->text_len = vc_ld16(r->p + 8);
  r->off = VC_ERROR_FIXED;
  if (m->text_len > VC_PROTO_MAX_ERROR_TEXT)
    return vc_diag_set(r->diag, VC_PROTO_ELIMIT, "ERROR: text_len %u > %d", m->text_len,
                       VC_PROTO_MAX_ERROR_TEXT);
  if ((rc = need(r, m->text_len, "text (text_len)"))) return rc;
  m->text = (const char*)(r->p + r->off);
  r->off += m->text_len;
  if ((rc = finish(r))) return rc;
  return vc_check_error(m, r->diag);
}

static int parse_silhouette(reader* r, vc_silhouette* m) {
  int rc = need(r, VC_SILHOUETTE_FIXED, "the fixed part");
  if (rc) return rc;
  const uint8_t* p = r->p;
  m->camera = vc_ld16(p + 0);
  m->scale = vc_ld16(p + 2);
  m->width = vc_ld16(p + 4);
  m->height = vc_ld16(p + 6);
  m->rle_len = vc_ld32(p + 8);
  m->foreground_count = vc_ld32(p + 12);
  r->off = VC_SILHOUETTE_FIXED;
  if ((rc = need(r, m->rle_len, "rle (rle_len)"))) return rc;
  m->rle = p + VC_SILHOUETTE_FIXED;
  r->off += m->rle_len;
  if ((rc = finish(r))) return rc;
  return vc_check_silhouette(m, &m->run_count, r->diag);
}

static int parse_auth(reader* r, vc_auth_msg* m) {
  int rc = need(r, VC_AUTH_MSG_SIZE, "the fields");
  if (rc) return rc;
  const uint8_t* p = r->p;
  m->step = vc_ld16(p + 0);
  uint16_t reserved = vc_ld16(p + 2);
  memcpy(m->nonce, p + 4, sizeof m->nonce);
  memcpy(m->proof, p + 36, sizeof m->proof);
  r->off = VC_AUTH_MSG_SIZE;
  if ((rc = finish(r))) return rc;
  return vc_check_auth(m, reserved, r->diag);
}

static int parse_grab(reader* r, vc_grab* m) {
  int rc = need(r, VC_GRAB_SIZE, "the fields");
  if (rc) return rc;
  const uint8_t* p = r->p;
  m->every = vc_ld16(p + 0);
  m->format = vc_ld16(p + 2);
  m->cameras = vc_ld16(p + 4);
  uint16_t reserved = vc_ld16(p + 6);
  m->count = vc_ld32(p + 8);
  r->off = VC_GRAB_SIZE;
  if ((rc = finish(r))) return rc;
  return vc_check_grab(m, reserved, r->diag);
}

static int parse_frame(reader* r, vc_frame_msg* m) {
  int rc = need(r, VC_FRAME_FIXED, "the fixed part");
  if (rc) return rc;
  const uint8_t* p = r->p;
  m->camera = vc_ld16(p + 0);
  m->format = vc_ld16(p + 2);
  m->width = vc_ld16(p + 4);
  m->height = vc_ld16(p + 6);
  m->pixels_len = vc_ld32(p + 8);
  r->off = VC_FRAME_FIXED;
  /* the sizes first: pixels_len must be what width x height says before it is trusted for a read */
  if ((rc = vc_check_frame(m, r->diag))) return rc;
  if ((rc = need(r, m->pixels_len, "pixels (pixels_len)"))) return rc;
  m->pixels = p + VC_FRAME_FIXED;
  r->off += m->pixels_len;
  return finish(r);
}

static int parse_body(vc_msg* m, vc_proto_diag* diag) {
  reader r = {m->payload,
              m->hdr.payload_len,
              0,
              vc_msg_type_name(m->hdr.type),
              m->hdr.version_minor > VC_PROTO_VERSION_MINOR,
              0,
              diag};
  int rc;
  switch (m->hdr.type) {
    case VC_MSG_HELLO:
      rc = parse_hello(&r, &m->u.hello, m->hdr.node_id);
      break;
    case VC_MSG_CONFIG:
      rc = parse_config(&r, &m->u.config);
      break;
    case VC_MSG_BACKGROUND:
      rc = parse_background(&r, &m->u.background);
      break;
    case VC_MSG_START:
    case VC_MSG_STOP:
      rc = finish(&r);
      break;
    case VC_MSG_HULL:
      rc = parse_hull(&r, &m->u.hull);
      break;
    case VC_MSG_FEATURES:
      rc = parse_features(&r, &m->u.features);
      break;
    case VC_MSG_STATS:
      rc = parse_stats(&r, &m->u.stats);
      break;
    case VC_MSG_HEARTBEAT:
      rc = parse_heartbeat(&r, &m->u.heartbeat);
      break;
    case VC_MSG_ERROR:
      rc = parse_error(&r, &m->u.error);
      break;
    case VC_MSG_SILHOUETTE:
      rc = parse_silhouette(&r, &m->u.silhouette);
      break;
    case VC_MSG_AUTH:
      rc = parse_auth(&r, &m->u.auth);
      break;
    case VC_MSG_GRAB:
      rc = parse_grab(&r, &m->u.grab);
      break;
    case VC_MSG_FRAME:
      rc = parse_frame(&r, &m->u.frame);
      break;
    default:
      return 0; /* unknown type: reported with known = false, body left unset */
  }
  m->ignored_bytes = r.ignored;
  return rc;
}

int vc_msg_decode(const uint8_t* buf, size_t len, size_t max_payload, vc_msg* out, size_t* consumed,
                  vc_proto_diag* diag) {
  return vc_msg_decode_mac(buf, len, max_payload, NULL, out, consumed, diag);
}

int vc_msg_decode_mac(const uint8_t* buf, size_t len, size_t max_payload, struct vc_mac* rx, vc_msg* out,
                      size_t* consumed, vc_proto_diag* diag) {
  if ((len && !buf) || !out || !consumed) return -EINVAL;
  if (max_payload == 0) max_payload = VC_PROTO_MAX_PAYLOAD;
  if (max_payload > VC_PROTO_MAX_PAYLOAD) return -EINVAL;
  *consumed = 0;
  if (diag) {
    diag->code = 0;
    diag->offset = 0;
    diag->detail[0] = '\0';
  }
  uint8_t magic[4];
  vc_st32(magic, VC_PROTO_MAGIC);
  for (size_t i = 0; i < len && i < 4; i++)
    if (buf[i] != magic[i])
      return vc_diag_set(diag, VC_PROTO_EMAGIC, "expected \"VXCP\", byte %zu is 0x%02x", i, buf[i]);
  if (len > 4 && buf[4] != VC_PROTO_VERSION_MAJOR)
    return vc_diag_set(diag, VC_PROTO_EVERSION, "version_major %u, this receiver speaks %d.x", buf[4],
                       VC_PROTO_VERSION_MAJOR);
  if (len < VC_PROTO_HEADER_SIZE) return 0;

  memset(out, 0, sizeof *out);
  vc_header* h = &out->hdr;
  h->version_major = buf[4];
  h->version_minor = buf[5];
  h->type = vc_ld16(buf + 6);
  h->flags = vc_ld16(buf + 8);
  h->node_id = vc_ld16(buf + 10);
  h->payload_len = vc_ld32(buf + 12);
  h->seq = vc_ld64(buf + 16);
  h->t_trigger_ns = vc_ld64(buf + 24);
  h->payload_crc = vc_ld32(buf + 32);
  h->header_crc = vc_ld32(buf + 36);
  uint32_t crc = vc_crc32c(0, buf, 36);
  if (crc != h->header_crc)
    return vc_diag_set(diag, VC_PROTO_EHEADER_CRC, "header_crc 0x%08x, bytes 0..35 give 0x%08x",
                       h->header_crc, crc);
  if (h->payload_len > max_payload)
    return vc_diag_set(diag, VC_PROTO_EOVERSIZE, "payload_len %u > limit %zu (type %u)", h->payload_len,
                       max_payload, h->type);
  if (len - VC_PROTO_HEADER_SIZE < h->payload_len) return 0;
  out->payload = buf + VC_PROTO_HEADER_SIZE;
  crc = vc_crc32c(0, out->payload, h->payload_len);
  if (crc != h->payload_crc)
    return vc_diag_set(diag, VC_PROTO_EPAYLOAD_CRC, "payload_crc 0x%08x, the %u payload bytes give 0x%08x",
                       h->payload_crc, h->payload_len, crc);
  /* From here on the frame is sound: whatever the payload holds, the message is consumed. */
  *consumed = VC_PROTO_HEADER_SIZE + (size_t)h->payload_len;
  if (rx) { /* 2.3: the MAC before anything reads the payload; the trailer is not the message's */
    int mrc = vc_mac_open(rx, buf, *consumed, diag);
    if (mrc) return mrc;
    h->payload_len -= VC_AUTH_TRAILER_SIZE;
  }
  out->known = vc_msg_type_name(h->type) != NULL;
  int rc = parse_body(out, diag);
  return rc ? rc : 1;
}
