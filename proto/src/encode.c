/* Encoders (SPEC.md "Framing", "Messages"). Each computes the payload size, checks the body with the
 * decoder's own rules, writes the payload at buf + 40 and then seals the header (lengths, CRCs).
 * No allocation anywhere: HULL and FEATURES run per frame on the edge. */
#include <errno.h>
#include <string.h>

#include "internal.h"
#include "voxcap/crc32c.h"
#include "voxcap/rle.h"
#include "wire.h"

/* Checks arguments and room for a payload of plen bytes; sets *len to the message size. */
static int frame_begin(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, size_t plen) {
  if (!len || !hdr || (cap && !buf)) return -EINVAL;
  if (plen > VC_PROTO_MAX_PAYLOAD) return VC_PROTO_ELIMIT;
  *len = VC_PROTO_HEADER_SIZE + plen;
  return cap >= *len ? 0 : -ENOSPC;
}

/* Writes the header for the payload already at buf + 40. */
static void frame_seal(uint8_t* buf, const vc_header* hdr, uint8_t major, uint8_t minor, uint16_t type,
                       size_t plen) {
  vc_st32(buf + 0, VC_PROTO_MAGIC);
  buf[4] = major;
  buf[5] = minor;
  vc_st16(buf + 6, type);
  vc_st16(buf + 8, hdr->flags);
  vc_st16(buf + 10, hdr->node_id);
  vc_st32(buf + 12, (uint32_t)plen);
  vc_st64(buf + 16, hdr->seq);
  vc_st64(buf + 24, hdr->t_trigger_ns);
  vc_st32(buf + 32, vc_crc32c(0, buf + VC_PROTO_HEADER_SIZE, plen));
  vc_st32(buf + 36, vc_crc32c(0, buf, 36));
}

static void seal(uint8_t* buf, const vc_header* hdr, uint16_t type, size_t plen) {
  frame_seal(buf, hdr, VC_PROTO_VERSION_MAJOR, VC_PROTO_VERSION_MINOR, type, plen);
}

int vc_frame_encode(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const uint8_t* payload,
                    size_t payload_len) {
  if (payload_len && !payload) return -EINVAL;
  int rc = frame_begin(buf, cap, len, hdr, payload_len);
  if (rc) return rc;
  if (payload_len) memmove(buf + VC_PROTO_HEADER_SIZE, payload, payload_len);
  frame_seal(buf, hdr, hdr->version_major, hdr->version_minor, hdr->type, payload_len);
  return 0;
}

int vc_encode_hello(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_hello* m) {
  if (!m || !hdr) return -EINVAL;
  int rc = vc_check_hello(m, hdr->node_id, NULL);
  if (rc) return rc;
  size_t plen = VC_HELLO_FIXED + (size_t)m->camera_count * VC_HELLO_CAMERA_SIZE;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st16(p + 0, m->node_id);
  vc_st16(p + 2, m->sw_major);
  vc_st16(p + 4, m->sw_minor);
  vc_st16(p + 6, m->sw_patch);
  vc_st32(p + 8, m->capabilities);
  vc_st16(p + 12, m->camera_count);
  vc_st16(p + 14, VC_HELLO_CAMERA_SIZE);
  p += VC_HELLO_FIXED;
  for (unsigned i = 0; i < m->camera_count; i++, p += VC_HELLO_CAMERA_SIZE) {
    const vc_hello_camera* c = &m->cameras[i];
    vc_st16(p + 0, c->width);
    vc_st16(p + 2, c->height);
    vc_st32(p + 4, c->pixel_format);
    vc_st32(p + 8, c->max_fps_milli);
  }
  seal(buf, hdr, VC_MSG_HELLO, plen);
  return 0;
}

int vc_encode_config(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_config* m) {
  if (!m || !hdr) return -EINVAL;
  int rc = vc_check_config(m, NULL);
  if (rc) return rc;
  size_t plen = VC_CONFIG_FIXED + (size_t)m->camera_count * VC_CONFIG_CAMERA_SIZE;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st32(p + 0, m->grid_id);
  vc_st32(p + 4, m->grid.nx);
  vc_st32(p + 8, m->grid.ny);
  vc_st32(p + 12, m->grid.nz);
  for (int i = 0; i < 3; i++) vc_stf64(p + 16 + 8 * i, m->grid.min_m[i]);
  vc_stf64(p + 40, m->grid.voxel_m);
  vc_stf32(p + 48, m->t_upper);
  vc_stf32(p + 52, m->t_lower);
  vc_stf32(p + 56, m->shadow_angle_deg);
  vc_st32(p + 60, m->cleanup_radius_px);
  vc_st16(p + 64, m->carve_rule);
  p[66] = m->silhouette_every;
  p[67] = m->silhouette_scale;
  vc_st32(p + 68, m->background_frames);
  vc_st16(p + 72, m->feature_role);
  vc_st16(p + 74, m->camera_count);
  vc_st16(p + 76, VC_CONFIG_CAMERA_SIZE);
  p += VC_CONFIG_FIXED;
  for (unsigned i = 0; i < m->camera_count; i++, p += VC_CONFIG_CAMERA_SIZE) {
    const vc_camera* c = &m->cameras[i];
    vc_st32(p + 0, c->width);
    vc_st32(p + 4, c->height);
    for (int k = 0; k < 9; k++) vc_stf64(p + 8 + 8 * k, c->K[k]);
    for (int k = 0; k < 5; k++) vc_stf64(p + 80 + 8 * k, c->dist[k]);
    for (int k = 0; k < 9; k++) vc_stf64(p + 120 + 8 * k, c->R_cam_from_world[k]);
    for (int k = 0; k < 3; k++) vc_stf64(p + 192 + 8 * k, c->t_cam_from_world[k]);
  }
  seal(buf, hdr, VC_MSG_CONFIG, plen);
  return 0;
}

int vc_encode_background(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr,
                         const vc_background* m) {
  if (!m) return -EINVAL;
  int rc = frame_begin(buf, cap, len, hdr, VC_BACKGROUND_SIZE);
  if (rc) return rc;
  vc_st32(buf + VC_PROTO_HEADER_SIZE, m->frame_count);
  seal(buf, hdr, VC_MSG_BACKGROUND, VC_BACKGROUND_SIZE);
  return 0;
}

static int encode_empty(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, uint16_t type) {
  int rc = frame_begin(buf, cap, len, hdr, 0);
  if (rc) return rc;
  seal(buf, hdr, type, 0);
  return 0;
}

int vc_encode_start(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr) {
  return encode_empty(buf, cap, len, hdr, VC_MSG_START);
}

int vc_encode_stop(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr) {
  return encode_empty(buf, cap, len, hdr, VC_MSG_STOP);
}

static void put_hull_fixed(uint8_t* p, uint32_t grid_id, uint32_t rle_len, uint64_t voxels,
                           uint64_t occupied) {
  vc_st32(p + 0, grid_id);
  vc_st32(p + 4, rle_len);
  vc_st64(p + 8, voxels);
  vc_st64(p + 16, occupied);
}

int vc_encode_hull(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_hull* m) {
  if (!m || !hdr) return -EINVAL;
  int rc = vc_check_hull(m, NULL, NULL);
  if (rc) return rc;
  size_t plen = VC_HULL_FIXED + (size_t)m->rle_len;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  put_hull_fixed(p, m->grid_id, m->rle_len, m->voxel_count, m->occupied_count);
  if (m->rle_len) memmove(p + VC_HULL_FIXED, m->rle, m->rle_len);
  seal(buf, hdr, VC_MSG_HULL, plen);
  return 0;
}

/* The RLE of `nbits` bits straight into a HULL's or SILHOUETTE's payload, after its `fixed` bytes (the
 * caller then writes those and seals): *len is the whole message's size, also when it does not fit (-ENOSPC,
 * *len the size needed); VC_PROTO_ELIMIT when the runs or the payload exceed the protocol's limits. */
static int encode_rle_payload(uint8_t* buf, size_t cap, size_t* len, size_t fixed_payload,
                              const uint8_t* bits, size_t nbits, size_t* rle_len, vc_rle_info* info) {
  const size_t fixed = VC_PROTO_HEADER_SIZE + fixed_payload;
  uint8_t* rle = cap >= fixed ? buf + fixed : NULL;
  const size_t rle_cap = cap >= fixed ? cap - fixed : 0;
  int rc = vc_rle_encode_info(bits, nbits, rle, rle_cap, rle_len, info);
  *len = fixed + *rle_len;
  if (info->runs > VC_PROTO_MAX_RLE_RUNS || fixed_payload + *rle_len > VC_PROTO_MAX_PAYLOAD)
    return VC_PROTO_ELIMIT;
  return rc; /* 0, or -ENOSPC with *len the size needed */
}

int vc_encode_hull_bits(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, uint32_t grid_id,
                        const uint8_t* bits, size_t nbits) {
  if (!len || !hdr || (cap && !buf) || (nbits && !bits)) return -EINVAL;
  if (nbits > VC_PROTO_MAX_VOXELS) return VC_PROTO_ELIMIT;
  size_t rle_len = 0;
  vc_rle_info info;
  int rc = encode_rle_payload(buf, cap, len, VC_HULL_FIXED, bits, nbits, &rle_len, &info);
  if (rc) return rc;
  put_hull_fixed(buf + VC_PROTO_HEADER_SIZE, grid_id, (uint32_t)rle_len, nbits, info.occupied);
  seal(buf, hdr, VC_MSG_HULL, VC_HULL_FIXED + rle_len);
  return 0;
}

int vc_encode_features(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_features* m) {
  if (!m) return -EINVAL;
  int rc = vc_check_features(m, NULL);
  if (rc) return rc;
  size_t plen = VC_FEATURES_FIXED + (size_t)m->feature_count * VC_FEATURE_SIZE;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st16(p + 0, m->camera);
  vc_st16(p + 2, m->feature_count);
  vc_st16(p + 4, VC_FEATURE_SIZE);
  p += VC_FEATURES_FIXED;
  for (unsigned i = 0; i < m->feature_count; i++, p += VC_FEATURE_SIZE) {
    const vc_feature* f = &m->features[i];
    vc_st16(p + 0, f->feature_id);
    vc_st16(p + 2, f->state);
    vc_stf32(p + 4, f->u);
    vc_stf32(p + 8, f->v);
    vc_stf32(p + 12, f->confidence);
  }
  seal(buf, hdr, VC_MSG_FEATURES, plen);
  return 0;
}

int vc_encode_stats(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_stats* m) {
  if (!m) return -EINVAL;
  int rc = vc_check_stats(m, NULL);
  if (rc) return rc;
  size_t plen =
      VC_STATS_FIXED + (size_t)m->stage_count * VC_STAGE_SIZE + (size_t)m->counter_count * VC_COUNTER_SIZE;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st32(p + 0, m->frames);
  vc_st16(p + 4, m->stage_count);
  vc_st16(p + 6, m->counter_count);
  p += VC_STATS_FIXED;
  for (unsigned i = 0; i < m->stage_count; i++, p += VC_STAGE_SIZE) {
    vc_st32(p + 0, m->stages[i].stage_id);
    vc_st32(p + 4, m->stages[i].mean_ns);
    vc_st32(p + 8, m->stages[i].max_ns);
  }
  for (unsigned i = 0; i < m->counter_count; i++, p += VC_COUNTER_SIZE) {
    vc_st32(p + 0, m->counters[i].counter_id);
    vc_st64(p + 4, m->counters[i].value);
  }
  seal(buf, hdr, VC_MSG_STATS, plen);
  return 0;
}

int vc_encode_heartbeat(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_heartbeat* m) {
  if (!m) return -EINVAL;
  int rc = vc_check_heartbeat(m, NULL);
  if (rc) return rc;
  if ((rc = frame_begin(buf, cap, len, hdr, VC_HEARTBEAT_SIZE))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st64(p + 0, m->sender_time_ns);
  vc_st32(p + 8, m->state);
  seal(buf, hdr, VC_MSG_HEARTBEAT, VC_HEARTBEAT_SIZE);
  return 0;
}

int vc_encode_error(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_error* m) {
  if (!m) return -EINVAL;
  int rc = vc_check_error(m, NULL);
  if (rc) return rc;
  size_t plen = VC_ERROR_FIXED + (size_t)m->text_len;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st32(p + 0, m->code);
  vc_st16(p + 4, m->severity);
  vc_st16(p + 6, m->about_type);
  vc_st16(p + 8, m->text_len);
  if (m->text_len) memmove(p + VC_ERROR_FIXED, m->text, m->text_len);
  seal(buf, hdr, VC_MSG_ERROR, plen);
  return 0;
}

static void put_silhouette_fixed(uint8_t* p, uint16_t camera, uint16_t scale, uint16_t width, uint16_t height,
                                 uint32_t rle_len, uint32_t foreground) {
  vc_st16(p + 0, camera);
  vc_st16(p + 2, scale);
  vc_st16(p + 4, width);
  vc_st16(p + 6, height);
  vc_st32(p + 8, rle_len);
  vc_st32(p + 12, foreground);
}

int vc_encode_silhouette(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr,
                         const vc_silhouette* m) {
  if (!m || !hdr) return -EINVAL;
  int rc = vc_check_silhouette(m, NULL, NULL);
  if (rc) return rc;
  size_t plen = VC_SILHOUETTE_FIXED + (size_t)m->rle_len;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  put_silhouette_fixed(p, m->camera, m->scale, m->width, m->height, m->rle_len, m->foreground_count);
  if (m->rle_len) memmove(p + VC_SILHOUETTE_FIXED, m->rle, m->rle_len);
  seal(buf, hdr, VC_MSG_SILHOUETTE, plen);
  return 0;
}

int vc_encode_silhouette_bits(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, uint16_t camera,
                              uint16_t scale, uint16_t width, uint16_t height, const uint8_t* bits) {
  if (!len || !hdr || (cap && !buf) || !bits) return -EINVAL;
  int rc = vc_check_silhouette_fields(camera, scale, width, height, NULL);
  if (rc) return rc;
  size_t rle_len = 0;
  vc_rle_info info;
  rc = encode_rle_payload(buf, cap, len, VC_SILHOUETTE_FIXED, bits, (size_t)width * height, &rle_len, &info);
  if (rc) return rc;
  put_silhouette_fixed(buf + VC_PROTO_HEADER_SIZE, camera, scale, width, height, (uint32_t)rle_len,
                       (uint32_t)info.occupied);
  seal(buf, hdr, VC_MSG_SILHOUETTE, VC_SILHOUETTE_FIXED + rle_len);
  return 0;
}

int vc_encode_auth(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_auth_msg* m) {
  if (!m || !hdr) return -EINVAL;
  int rc = vc_check_auth(m, 0, NULL);
  if (rc) return rc;
  if ((rc = frame_begin(buf, cap, len, hdr, VC_AUTH_MSG_SIZE))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st16(p + 0, m->step);
  vc_st16(p + 2, 0);
  memcpy(p + 4, m->nonce, sizeof m->nonce);
  memcpy(p + 36, m->proof, sizeof m->proof);
  seal(buf, hdr, VC_MSG_AUTH, VC_AUTH_MSG_SIZE);
  return 0;
}

int vc_encode_grab(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_grab* m) {
  if (!m || !hdr) return -EINVAL;
  int rc = vc_check_grab(m, 0, NULL);
  if (rc) return rc;
  if ((rc = frame_begin(buf, cap, len, hdr, VC_GRAB_SIZE))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  vc_st16(p + 0, m->every);
  vc_st16(p + 2, m->format);
  vc_st16(p + 4, m->cameras);
  vc_st16(p + 6, 0);
  vc_st32(p + 8, m->count);
  seal(buf, hdr, VC_MSG_GRAB, VC_GRAB_SIZE);
  return 0;
}

static void put_frame_fixed(uint8_t* p, uint16_t camera, uint16_t format, uint16_t width, uint16_t height,
                            uint32_t pixels_len) {
  vc_st16(p + 0, camera);
  vc_st16(p + 2, format);
  vc_st16(p + 4, width);
  vc_st16(p + 6, height);
  vc_st32(p + 8, pixels_len);
}

int vc_encode_frame(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, const vc_frame_msg* m) {
  if (!m || !hdr || (m->pixels_len && !m->pixels)) return -EINVAL;
  int rc = vc_check_frame(m, NULL);
  if (rc) return rc;
  size_t plen = VC_FRAME_FIXED + (size_t)m->pixels_len;
  if ((rc = frame_begin(buf, cap, len, hdr, plen))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  put_frame_fixed(p, m->camera, m->format, m->width, m->height, m->pixels_len);
  memmove(p + VC_FRAME_FIXED, m->pixels, m->pixels_len);
  seal(buf, hdr, VC_MSG_FRAME, plen);
  return 0;
}

int vc_encode_frame_rgb(uint8_t* buf, size_t cap, size_t* len, const vc_header* hdr, uint16_t camera,
                        uint16_t format, uint16_t width, uint16_t height, const uint8_t* rgb, size_t stride) {
  if (!len || !hdr || (cap && !buf) || !rgb || stride < (size_t)width * 3) return -EINVAL;
  int rc = vc_check_frame_fields(camera, format, width, height, NULL);
  if (rc) return rc;
  const unsigned ch = vc_frame_format_channels(format);
  const size_t row = (size_t)width * ch, pixels = row * height;
  if ((rc = frame_begin(buf, cap, len, hdr, VC_FRAME_FIXED + pixels))) return rc;
  uint8_t* p = buf + VC_PROTO_HEADER_SIZE;
  put_frame_fixed(p, camera, format, width, height, (uint32_t)pixels);
  uint8_t* out = p + VC_FRAME_FIXED;
  for (unsigned y = 0; y < height; y++, out += row) {
    const uint8_t* in = rgb + (size_t)y * stride;
    if (ch == 3) {
      memcpy(out, in, row);
    } else { /* Q8 luma, BT.601: (77 R + 150 G + 29 B + 128) >> 8, the weights sum to 256 */
      for (unsigned x = 0; x < width; x++, in += 3)
        out[x] = (uint8_t)((77u * in[0] + 150u * in[1] + 29u * in[2] + 128u) >> 8);
    }
  }
  seal(buf, hdr, VC_MSG_FRAME, VC_FRAME_FIXED + pixels);
  return 0;
}

int vc_msg_encode(uint8_t* buf, size_t cap, size_t* len, const vc_msg* msg) {
  if (!msg) return -EINVAL;
  const vc_header* h = &msg->hdr;
  switch (h->type) {
    case VC_MSG_HELLO:
      return vc_encode_hello(buf, cap, len, h, &msg->u.hello);
    case VC_MSG_CONFIG:
      return vc_encode_config(buf, cap, len, h, &msg->u.config);
    case VC_MSG_BACKGROUND:
      return vc_encode_background(buf, cap, len, h, &msg->u.background);
    case VC_MSG_START:
      return vc_encode_start(buf, cap, len, h);
    case VC_MSG_STOP:
      return vc_encode_stop(buf, cap, len, h);
    case VC_MSG_HULL:
      return vc_encode_hull(buf, cap, len, h, &msg->u.hull);
    case VC_MSG_FEATURES:
      return vc_encode_features(buf, cap, len, h, &msg->u.features);
    case VC_MSG_STATS:
      return vc_encode_stats(buf, cap, len, h, &msg->u.stats);
    case VC_MSG_HEARTBEAT:
      return vc_encode_heartbeat(buf, cap, len, h, &msg->u.heartbeat);
    case VC_MSG_ERROR:
      return vc_encode_error(buf, cap, len, h, &msg->u.error);
    case VC_MSG_SILHOUETTE:
      return vc_encode_silhouette(buf, cap, len, h, &msg->u.silhouette);
    case VC_MSG_AUTH:
      return vc_encode_auth(buf, cap, len, h, &msg->u.auth);
    case VC_MSG_GRAB:
      return vc_encode_grab(buf, cap, len, h, &msg->u.grab);
    case VC_MSG_FRAME:
      return vc_encode_frame(buf, cap, len, h, &msg->u.frame);
    default:
      return -EINVAL;
  }
}
