/* Body rules of SPEC.md "Messages", shared by the encoders (so a sender cannot produce what a
 * receiver rejects) and the decoder. Framing and lengths are checked elsewhere (decode.c); here
 * only field values and the agreement between fields. */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#include "internal.h"
#include "voxcap/rle.h"

int vc_diag_set(vc_proto_diag* diag, int code, const char* fmt, ...) {
  if (diag) {
    diag->code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(diag->detail, sizeof diag->detail, fmt, ap);
    va_end(ap);
  }
  return code;
}

static bool all_finite(const double* v, size_t n) {
  for (size_t i = 0; i < n; i++)
    if (!isfinite(v[i])) return false;
  return true;
}

int vc_check_hello(const vc_hello* m, uint16_t header_node_id, vc_proto_diag* diag) {
  if (m->camera_count > VC_PROTO_MAX_CAMERAS)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "HELLO: camera_count %u > %d", m->camera_count,
                       VC_PROTO_MAX_CAMERAS);
  if (m->node_id != header_node_id)
    return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "HELLO: node_id %u != header node_id %u", m->node_id,
                       header_node_id);
  for (unsigned i = 0; i < m->camera_count; i++) {
    const vc_hello_camera* c = &m->cameras[i];
    if (c->width == 0 || c->height == 0)
      return vc_diag_set(diag, VC_PROTO_EFIELD, "HELLO: cameras[%u] has size %ux%u", i, c->width, c->height);
  }
  return 0;
}

int vc_check_config(const vc_config* m, vc_proto_diag* diag) {
  if (m->camera_count == 0) return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: camera_count 0");
  if (m->camera_count > VC_PROTO_MAX_CAMERAS)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "CONFIG: camera_count %u > %d", m->camera_count,
                       VC_PROTO_MAX_CAMERAS);
  if (m->grid.nx == 0 || m->grid.ny == 0 || m->grid.nz == 0)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: grid %ux%ux%u has no voxels", m->grid.nx, m->grid.ny,
                       m->grid.nz);
  uint64_t xy = (uint64_t)m->grid.nx * m->grid.ny; /* < 2^64: two u32 */
  if (xy > VC_PROTO_MAX_VOXELS || xy * m->grid.nz > VC_PROTO_MAX_VOXELS)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "CONFIG: grid %ux%ux%u has more than %llu voxels", m->grid.nx,
                       m->grid.ny, m->grid.nz, (unsigned long long)VC_PROTO_MAX_VOXELS);
  if (!all_finite(m->grid.min_m, 3)) return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: min_m is not finite");
  if (!(isfinite(m->grid.voxel_m) && m->grid.voxel_m > 0))
    return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: voxel_m %g is not > 0", m->grid.voxel_m);
  if (!(isfinite(m->t_upper) && isfinite(m->t_lower) && m->t_lower >= 0 && m->t_lower <= m->t_upper))
    return vc_diag_set(diag, VC_PROTO_EFIELD,
                       "CONFIG: need 0 <= t_lower <= t_upper, got t_lower %g t_upper %g", (double)m->t_lower,
                       (double)m->t_upper);
  if (!(m->shadow_angle_deg >= 0 && m->shadow_angle_deg <= 180))
    return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: shadow_angle_deg %g is not in [0, 180]",
                       (double)m->shadow_angle_deg);
  if (m->cleanup_radius_px > VC_CLEANUP_RADIUS_MAX_PX)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: cleanup_radius_px %u is not in [0, %d]",
                       m->cleanup_radius_px, VC_CLEANUP_RADIUS_MAX_PX);
  if (m->carve_rule >= VC_CARVE_RULE_COUNT)
    return vc_diag_set(diag, VC_PROTO_EFIELD,
                       "CONFIG: unknown carve_rule %u (0 centre, 1 footprint, 2 subpixel)", m->carve_rule);
  if (m->silhouette_scale > VC_PROTO_MAX_SILHOUETTE_SCALE || (m->silhouette_every && !m->silhouette_scale))
    return vc_diag_set(diag, VC_PROTO_EFIELD,
                       "CONFIG: silhouette_scale %u is not in [1, %d] (silhouette_every %u)",
                       m->silhouette_scale, VC_PROTO_MAX_SILHOUETTE_SCALE, m->silhouette_every);
  if (m->background_frames == 0) return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: background_frames 0");
  if (vc_role_name(m->feature_role) == NULL)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: unknown feature_role %u", m->feature_role);
  for (unsigned i = 0; i < m->camera_count; i++) {
    const vc_camera* c = &m->cameras[i];
    if (c->width == 0 || c->height == 0)
      return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: cameras[%u] has size %ux%u", i, c->width, c->height);
    if (!all_finite(c->K, 9) || !all_finite(c->dist, 5) || !all_finite(c->R_cam_from_world, 9) ||
        !all_finite(c->t_cam_from_world, 3))
      return vc_diag_set(diag, VC_PROTO_EFIELD, "CONFIG: cameras[%u] has a non-finite parameter", i);
  }
  return 0;
}

/* The RLE payload of a HULL or SILHOUETTE: canonical, within the run limit, covering exactly `bits` bits of
 * which `ones` are set (what the message's own count fields say, named for the diagnostics). */
static int check_rle_payload(const char* type, const uint8_t* rle, uint32_t rle_len, uint64_t bits,
                             const char* bits_field, uint64_t ones, const char* ones_field, uint64_t* runs,
                             vc_proto_diag* diag) {
  if (rle_len && !rle) return vc_diag_set(diag, -EINVAL, "%s: rle is NULL", type);
  vc_rle_info info;
  if (vc_rle_inspect(rle, rle_len, &info))
    return vc_diag_set(diag, VC_PROTO_ERLE, "%s: RLE is malformed (bad varint or zero run)", type);
  if (info.runs > VC_PROTO_MAX_RLE_RUNS)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "%s: %llu runs > %llu", type, (unsigned long long)info.runs,
                       (unsigned long long)VC_PROTO_MAX_RLE_RUNS);
  if (info.total != bits)
    return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "%s: runs sum to %llu, %s is %llu", type,
                       (unsigned long long)info.total, bits_field, (unsigned long long)bits);
  if (info.occupied != ones)
    return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "%s: occupied runs sum to %llu, %s is %llu", type,
                       (unsigned long long)info.occupied, ones_field, (unsigned long long)ones);
  if (runs) *runs = info.runs;
  return 0;
}

int vc_check_hull(const vc_hull* m, uint64_t* runs, vc_proto_diag* diag) {
  if (m->voxel_count > VC_PROTO_MAX_VOXELS)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "HULL: voxel_count %llu > %llu",
                       (unsigned long long)m->voxel_count, (unsigned long long)VC_PROTO_MAX_VOXELS);
  return check_rle_payload("HULL", m->rle, m->rle_len, m->voxel_count, "voxel_count", m->occupied_count,
                           "occupied_count", runs, diag);
}

int vc_check_features(const vc_features* m, vc_proto_diag* diag) {
  if (m->camera >= VC_PROTO_MAX_CAMERAS)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "FEATURES: camera %u >= %d", m->camera, VC_PROTO_MAX_CAMERAS);
  if (m->feature_count > VC_PROTO_MAX_FEATURES)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "FEATURES: feature_count %u > %d", m->feature_count,
                       VC_PROTO_MAX_FEATURES);
  uint32_t seen = 0;
  for (unsigned i = 0; i < m->feature_count; i++) {
    const vc_feature* f = &m->features[i];
    if (f->feature_id >= VC_FEATURE_ID_COUNT)
      return vc_diag_set(diag, VC_PROTO_EFIELD, "FEATURES: features[%u] has unknown feature_id %u", i,
                         f->feature_id);
    if (seen & (1u << f->feature_id))
      return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "FEATURES: feature_id %u appears twice",
                         f->feature_id);
    seen |= 1u << f->feature_id;
    if (f->state >= VC_FEATURE_STATE_COUNT)
      return vc_diag_set(diag, VC_PROTO_EFIELD, "FEATURES: features[%u] has unknown state %u", i, f->state);
    if (!isfinite(f->u) || !isfinite(f->v))
      return vc_diag_set(diag, VC_PROTO_EFIELD, "FEATURES: features[%u] has a non-finite position", i);
    if (!(f->confidence >= 0 && f->confidence <= 1))
      return vc_diag_set(diag, VC_PROTO_EFIELD, "FEATURES: features[%u] confidence %g is not in [0, 1]", i,
                         (double)f->confidence);
  }
  return 0;
}

int vc_check_stats(const vc_stats* m, vc_proto_diag* diag) {
  if (m->stage_count > VC_PROTO_MAX_STAGES)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "STATS: stage_count %u > %d", m->stage_count,
                       VC_PROTO_MAX_STAGES);
  if (m->counter_count > VC_PROTO_MAX_COUNTERS)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "STATS: counter_count %u > %d", m->counter_count,
                       VC_PROTO_MAX_COUNTERS);
  for (unsigned i = 0; i < m->stage_count; i++) {
    const vc_stage_time* s = &m->stages[i];
    if (s->mean_ns > s->max_ns)
      return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "STATS: stage %u mean_ns %u > max_ns %u", s->stage_id,
                         s->mean_ns, s->max_ns);
    for (unsigned j = 0; j < i; j++)
      if (m->stages[j].stage_id == s->stage_id)
        return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "STATS: stage_id %u appears twice", s->stage_id);
  }
  for (unsigned i = 0; i < m->counter_count; i++)
    for (unsigned j = 0; j < i; j++)
      if (m->counters[j].counter_id == m->counters[i].counter_id)
        return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "STATS: counter_id %u appears twice",
                           m->counters[i].counter_id);
  return 0;
}

int vc_check_heartbeat(const vc_heartbeat* m, vc_proto_diag* diag) {
  if (m->state >= VC_STATE_COUNT)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "HEARTBEAT: unknown state %u", m->state);
  return 0;
}

/* Well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates, <= U+10FFFF) without NUL.
 * Returns the offset of the first bad byte, or n if all is well. */
static size_t utf8_check(const uint8_t* s, size_t n) {
  size_t i = 0;
  while (i < n) {
    uint8_t c = s[i];
    if (c == 0) return i;
    if (c < 0x80) {
      i++;
      continue;
    }
    size_t len;
    uint32_t cp, min;
    if ((c & 0xE0) == 0xC0) {
      len = 2, cp = c & 0x1F, min = 0x80;
    } else if ((c & 0xF0) == 0xE0) {
      len = 3, cp = c & 0x0F, min = 0x800;
    } else if ((c & 0xF8) == 0xF0) {
      len = 4, cp = c & 0x07, min = 0x10000;
    } else {
      return i;
    }
    if (n - i < len) return i;
    for (size_t k = 1; k < len; k++) {
      if ((s[i + k] & 0xC0) != 0x80) return i;
      cp = (cp << 6) | (s[i + k] & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return i;
    i += len;
  }
  return n;
}

int vc_check_error(const vc_error* m, vc_proto_diag* diag) {
  if (m->severity >= VC_SEVERITY_COUNT)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "ERROR: unknown severity %u", m->severity);
  if (m->text_len > VC_PROTO_MAX_ERROR_TEXT)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "ERROR: text_len %u > %d", m->text_len,
                       VC_PROTO_MAX_ERROR_TEXT);
  if (m->text_len && !m->text) return vc_diag_set(diag, -EINVAL, "ERROR: text is NULL");
  size_t bad = m->text_len ? utf8_check((const uint8_t*)m->text, m->text_len) : 0;
  if (bad < m->text_len)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "ERROR: text is not UTF-8 without NUL (byte %zu)", bad);
  return 0;
}

int vc_check_auth(const vc_auth_msg* m, uint16_t reserved, vc_proto_diag* diag) {
  if (m->step < VC_AUTH_CHALLENGE || m->step > VC_AUTH_PROOF)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "AUTH: unknown step %u", m->step);
  if (reserved != 0) return vc_diag_set(diag, VC_PROTO_EFIELD, "AUTH: reserved is %u, not 0", reserved);
  return 0;
}

int vc_check_silhouette_fields(uint16_t camera, uint16_t scale, uint16_t width, uint16_t height,
                               vc_proto_diag* diag) {
  if (camera >= VC_PROTO_MAX_CAMERAS)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "SILHOUETTE: camera %u >= %d", camera, VC_PROTO_MAX_CAMERAS);
  if (scale == 0 || scale > VC_PROTO_MAX_SILHOUETTE_SCALE)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "SILHOUETTE: scale %u is not in [1, %d]", scale,
                       VC_PROTO_MAX_SILHOUETTE_SCALE);
  if (width == 0 || height == 0)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "SILHOUETTE: size %ux%u has no pixels", width, height);
  if (width > VC_PROTO_MAX_SILHOUETTE_SIDE || height > VC_PROTO_MAX_SILHOUETTE_SIDE)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "SILHOUETTE: size %ux%u, at most %d each", width, height,
                       VC_PROTO_MAX_SILHOUETTE_SIDE);
  return 0;
}

int vc_check_silhouette(const vc_silhouette* m, uint64_t* runs, vc_proto_diag* diag) {
  int rc = vc_check_silhouette_fields(m->camera, m->scale, m->width, m->height, diag);
  if (rc) return rc;
  return check_rle_payload("SILHOUETTE", m->rle, m->rle_len, (uint64_t)m->width * m->height, "width x height",
                           m->foreground_count, "foreground_count", runs, diag);
}

int vc_check_grab(const vc_grab* m, uint16_t reserved, vc_proto_diag* diag) {
  if (reserved != 0) return vc_diag_set(diag, VC_PROTO_EFIELD, "GRAB: reserved is %u, not 0", reserved);
  if (m->every == 0) return 0; /* stop: the other fields are not read */
  if (vc_frame_format_channels(m->format) == 0)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "GRAB: unknown format %u (1 gray8, 2 rgb8)", m->format);
  if (m->cameras == 0 || (m->cameras >> VC_PROTO_MAX_CAMERAS) != 0)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "GRAB: cameras 0x%04x names no camera or one >= %d", m->cameras,
                       VC_PROTO_MAX_CAMERAS);
  return 0;
}

int vc_check_frame_fields(uint16_t camera, uint16_t format, uint16_t width, uint16_t height,
                          vc_proto_diag* diag) {
  if (camera >= VC_PROTO_MAX_CAMERAS)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "FRAME: camera %u >= %d", camera, VC_PROTO_MAX_CAMERAS);
  const unsigned ch = vc_frame_format_channels(format);
  if (ch == 0)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "FRAME: unknown format %u (1 gray8, 2 rgb8)", format);
  if (width == 0 || height == 0)
    return vc_diag_set(diag, VC_PROTO_EFIELD, "FRAME: size %ux%u has no pixels", width, height);
  if (width > VC_PROTO_MAX_FRAME_SIDE || height > VC_PROTO_MAX_FRAME_SIDE)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "FRAME: size %ux%u, at most %d each", width, height,
                       VC_PROTO_MAX_FRAME_SIDE);
  if ((uint64_t)width * height * ch > VC_PROTO_MAX_PAYLOAD - VC_FRAME_FIXED)
    return vc_diag_set(diag, VC_PROTO_ELIMIT, "FRAME: %ux%u %s is %llu bytes, over a payload of %u", width,
                       height, vc_frame_format_name(format), (unsigned long long)width * height * ch,
                       VC_PROTO_MAX_PAYLOAD);
  return 0;
}

int vc_check_frame(const vc_frame_msg* m, vc_proto_diag* diag) {
  int rc = vc_check_frame_fields(m->camera, m->format, m->width, m->height, diag);
  if (rc) return rc;
  const uint64_t want = (uint64_t)m->width * m->height * vc_frame_format_channels(m->format);
  if (m->pixels_len != want)
    return vc_diag_set(diag, VC_PROTO_EINCONSISTENT, "FRAME: pixels_len %u, %ux%u %s is %llu bytes",
                       m->pixels_len, m->width, m->height, vc_frame_format_name(m->format),
                       (unsigned long long)want);
  return 0;
}
