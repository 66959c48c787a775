/* The edge node's state machine and per-frame pipeline (see node.h). */
#define _GNU_SOURCE /* M_PI */
#include "node.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "voxcap/crc32c.h"
#include "voxcap/edge/bgmodel.h"
#include "voxcap/edge/carver.h"
#include "voxcap/edge/cleanup.h"
#include "voxcap/edge/clock.h"
#include "voxcap/rle.h"
#include "voxcap/why.h"

enum { ST_SUBTRACT, ST_CLEANUP, ST_CARVE, ST_ENCODE, ST_COUNT };
static const uint32_t stage_ids[ST_COUNT] = {VC_STAGE_SUBTRACT, VC_STAGE_CLEANUP, VC_STAGE_CARVE,
                                             VC_STAGE_ENCODE};

typedef struct stage_acc {
  uint64_t sum_ns;
  uint64_t max_ns;
} stage_acc;

struct vc_node {
  uint16_t id;
  vc_node_camera cams[VC_NODE_CAMS];
  uint32_t state;
  vc_config cfg; /* the applied CONFIG */
  bool have_cfg;

  vc_bgmodel* bg[VC_NODE_CAMS];
  bool bg_learnt; /* bg[] finished */
  uint32_t bg_wanted, bg_have;
  vc_subtract_params sub;
  int cleanup_radius; /* CONFIG's cleanup_radius_px: one pass of that majority filter */

  vc_carver* carver;
  uint8_t* masks[VC_NODE_CAMS];
  /* The tracker's masks: masks[] without the limb-scale cue's pixels (vc_mask_ungrown), made in a
   * frame whose cue grew some; NULL when the cue is off. grown[]: the cue's pixels this frame. */
  uint8_t* track_masks[VC_NODE_CAMS];
  uint32_t grown[VC_NODE_CAMS];
  uint8_t* scratch;
  size_t scratch_len;
  uint8_t* bitset;
  uint8_t* msgbuf;
  size_t msgcap;
  bool have_frame;

  /* SILHOUETTE (CONFIG's silhouette_every > 0): each camera's mask packed to a bitset at 1/scale,
   * and the message built from it; made at CONFIG, NULL otherwise. */
  uint8_t* silbits[VC_NODE_CAMS];
  uint8_t* silbuf[VC_NODE_CAMS];
  size_t silcap[VC_NODE_CAMS];
  uint16_t silw[VC_NODE_CAMS], silh[VC_NODE_CAMS];

  /* GRAB (2.4): the request in force (every 0: none) and one FRAME buffer per camera, made by GRAB. */
  vc_grab grab;
  uint64_t grab_first_seq;
  uint32_t grab_sent; /* frames sent for this GRAB */
  uint8_t* framebuf[VC_NODE_CAMS];
  size_t framecap[VC_NODE_CAMS];

  vc_features_producer producer; /* track == NULL: none */
  uint8_t featbuf[VC_NODE_CAMS][VC_PROTO_HEADER_SIZE + 6 + 16 * VC_PROTO_MAX_FEATURES];

  uint64_t first_seq;
  vc_node_counters counters;
  stage_acc stages[ST_COUNT];
  uint32_t stage_frames;
};

static uint64_t now_ns(void) {
  return vc_clock_monotonic_ns();
}

static void stage_add(vc_node* n, int st, uint64_t t0, uint64_t t1) {
  uint64_t d = t1 - t0;
  n->stages[st].sum_ns += d;
  if (d > n->stages[st].max_ns) n->stages[st].max_ns = d;
}

int vc_node_new(uint16_t node_id, const vc_node_camera cams[VC_NODE_CAMS], vc_node** out, char* why,
                size_t why_len) {
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if (!cams || !out) {
    vc_why(why, why_len, "node: invalid arguments");
    return -EINVAL;
  }
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    if (cams[c].width <= 0 || cams[c].height <= 0 || cams[c].width > 16384 || cams[c].height > 16384) {
      vc_why(why, why_len, "node: camera %d is %dx%d (1..16384 each)", c, cams[c].width, cams[c].height);
      return -EINVAL;
    }
  }
  vc_node* n = calloc(1, sizeof(*n));
  if (!n) {
    vc_why(why, why_len, "node: out of memory");
    return -ENOMEM;
  }
  n->id = node_id;
  memcpy(n->cams, cams, sizeof(n->cams));
  n->state = VC_STATE_IDLE;
  *out = n;
  return 0;
}

static void free_models(vc_node* n) {
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    vc_bgmodel_free(n->bg[c]);
    n->bg[c] = NULL;
  }
  n->bg_learnt = false;
}

void vc_node_free(vc_node* n) {
  if (!n) return;
  free_models(n);
  vc_carver_free(n->carver);
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    free(n->masks[c]);
    free(n->track_masks[c]);
    free(n->silbits[c]);
    free(n->silbuf[c]);
    free(n->framebuf[c]);
  }
  free(n->scratch);
  free(n->bitset);
  free(n->msgbuf);
  free(n);
}

int vc_node_hello(const vc_node* n, uint32_t capabilities, uint8_t* buf, size_t cap, size_t* len) {
  vc_hello h;
  memset(&h, 0, sizeof(h));
  h.node_id = n->id;
  h.sw_major = VOXCAP_VERSION_MAJOR; /* the release (CMake's project version): voxcap deploy checks it */
  h.sw_minor = VOXCAP_VERSION_MINOR;
  h.sw_patch = VOXCAP_VERSION_PATCH;
  h.capabilities = capabilities;
  h.camera_count = VC_NODE_CAMS;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    h.cameras[c].width = (uint16_t)n->cams[c].width;
    h.cameras[c].height = (uint16_t)n->cams[c].height;
    h.cameras[c].pixel_format = n->cams[c].pixel_format;
    h.cameras[c].max_fps_milli = n->cams[c].max_fps_milli;
  }
  vc_header hdr = {.node_id = n->id};
  return vc_encode_hello(buf, cap, len, &hdr, &h);
}

int vc_node_configure(vc_node* n, const vc_config* cfg, char* why, size_t why_len, char* warning,
                      size_t warning_len) {
  vc_why_clear(why, why_len);
  if (warning && warning_len) warning[0] = '\0';
  if (cfg->camera_count != VC_NODE_CAMS) {
    vc_why(why, why_len, "CONFIG has %u cameras, this node has %d", cfg->camera_count, VC_NODE_CAMS);
    return -EINVAL;
  }
  char bad[200]; /* a check's reason, passed on with what was checked */
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    const vc_camera* cc = &cfg->cameras[c];
    if ((int)cc->width != n->cams[c].width || (int)cc->height != n->cams[c].height) {
      vc_why(why, why_len, "CONFIG camera %d is %ux%u, the camera delivers %dx%d", c, cc->width, cc->height,
             n->cams[c].width, n->cams[c].height);
      return -EINVAL;
    }
    if (vc_camera_check(cc, bad, sizeof(bad)) < 0) {
      vc_why(why, why_len, "CONFIG camera %d: %s", c, bad);
      return -EINVAL;
    }
  }
  const vc_voxel_grid* grid = &cfg->grid;
  if (vc_grid_check(grid, bad, sizeof(bad)) < 0) {
    vc_why(why, why_len, "CONFIG grid: %s", bad);
    return -EINVAL;
  }
  vc_subtract_params sub;
  vc_subtract_params_default(&sub);
  sub.t_upper = cfg->t_upper;
  sub.t_lower = cfg->t_lower;
  double ang = cfg->shadow_angle_deg * M_PI / 180.0;
  sub.cos2_angular = cos(ang) * cos(ang);
  if (vc_subtract_params_check(&sub, bad, sizeof(bad)) < 0) {
    vc_why(why, why_len, "CONFIG thresholds: %s", bad);
    return -EINVAL;
  }
  if (cfg->cleanup_radius_px > VC_CLEANUP_MAX_RADIUS) { /* the decoder checks it too */
    vc_why(why, why_len, "CONFIG cleanup_radius_px %u: this edge runs 0..%d", cfg->cleanup_radius_px,
           VC_CLEANUP_MAX_RADIUS);
    return -EINVAL;
  }

  if (vc_carve_rule_name(cfg->carve_rule) == NULL) { /* and the decoder */
    vc_why(why, why_len, "CONFIG carve_rule %u: 0 centre, 1 footprint or 2 subpixel", cfg->carve_rule);
    return -EINVAL;
  }
  if (cfg->silhouette_every &&
      (cfg->silhouette_scale < 1 || cfg->silhouette_scale > VC_PROTO_MAX_SILHOUETTE_SCALE)) {
    vc_why(why, why_len, "CONFIG silhouette_scale %u: 1..%d", cfg->silhouette_scale,
           VC_PROTO_MAX_SILHOUETTE_SCALE);
    return -EINVAL;
  }

  vc_carver* carver = NULL;
  int rc = vc_carver_new(grid, &cfg->cameras[0], &cfg->cameras[1], (vc_carve_rule)cfg->carve_rule, &carver,
                         bad, sizeof(bad));
  if (rc < 0) {
    vc_why(why, why_len, "CONFIG: %s", bad);
    return rc;
  }
  size_t bits_bytes = vc_carver_bitset_bytes(carver);
  size_t msgcap = VC_PROTO_HEADER_SIZE + 64 + vc_rle_max_encoded_size(vc_carver_voxels(carver));
  uint8_t* bitset = malloc(bits_bytes);
  uint8_t* msgbuf = malloc(msgcap);
  size_t scratch_len = vc_cleanup_radius_scratch_size(
      n->cams[0].width > n->cams[1].width ? n->cams[0].width : n->cams[1].width, (int)cfg->cleanup_radius_px);
  uint8_t* scratch = malloc(scratch_len);
  uint8_t* masks[VC_NODE_CAMS] = {NULL, NULL};
  uint8_t* track_masks[VC_NODE_CAMS] = {NULL, NULL};
  bool track_ok = true;
  uint8_t *silbits[VC_NODE_CAMS] = {NULL, NULL}, *silbuf[VC_NODE_CAMS] = {NULL, NULL};
  size_t silcap[VC_NODE_CAMS] = {0, 0};
  uint16_t silw[VC_NODE_CAMS] = {0, 0}, silh[VC_NODE_CAMS] = {0, 0};
  bool sil_ok = true;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    masks[c] = calloc((size_t)n->cams[c].width * (size_t)n->cams[c].height, 1);
    if (sub.grow_px > 0) {
      track_masks[c] = malloc((size_t)n->cams[c].width * (size_t)n->cams[c].height);
      track_ok = track_ok && track_masks[c];
    }
    if (!cfg->silhouette_every) continue;
    const int s = cfg->silhouette_scale; /* cameras are <= 16384 wide and high: so are the masks */
    silw[c] = (uint16_t)((n->cams[c].width + s - 1) / s);
    silh[c] = (uint16_t)((n->cams[c].height + s - 1) / s);
    const size_t px = (size_t)silw[c] * silh[c];
    silbits[c] = malloc((px + 7) / 8);
    silcap[c] = VC_PROTO_HEADER_SIZE + 16 + vc_rle_max_encoded_size(px);
    silbuf[c] = malloc(silcap[c]);
    sil_ok = sil_ok && silbits[c] && silbuf[c];
  }
  if (!bitset || !msgbuf || !scratch || !masks[0] || !masks[1] || !sil_ok || !track_ok) {
    vc_why(why, why_len, "CONFIG: out of memory");
    free(bitset);
    free(msgbuf);
    free(scratch);
    for (int c = 0; c < VC_NODE_CAMS; c++) {
      free(masks[c]);
      free(track_masks[c]);
      free(silbits[c]);
      free(silbuf[c]);
    }
    vc_carver_free(carver);
    return -ENOMEM;
  }

  /* Commit: nothing below fails. */
  vc_carver_free(n->carver);
  n->carver = carver;
  free(n->bitset);
  n->bitset = bitset;
  free(n->msgbuf);
  n->msgbuf = msgbuf;
  n->msgcap = msgcap;
  free(n->scratch);
  n->scratch = scratch;
  n->scratch_len = scratch_len;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    free(n->masks[c]);
    n->masks[c] = masks[c];
    free(n->track_masks[c]);
    n->track_masks[c] = track_masks[c];
    n->grown[c] = 0;
    free(n->silbits[c]);
    n->silbits[c] = silbits[c];
    free(n->silbuf[c]);
    n->silbuf[c] = silbuf[c];
    n->silcap[c] = silcap[c];
    n->silw[c] = silw[c];
    n->silh[c] = silh[c];
  }
  n->have_frame = false;
  n->grab.every = 0; /* CONFIG ends a GRAB */
  n->cfg = *cfg;
  n->have_cfg = true;
  n->sub = sub;
  n->cleanup_radius = (int)cfg->cleanup_radius_px;
  if (n->bg_learnt) {
    /* A learnt background survives a new CONFIG: the cameras' sizes were checked above. */
    for (int c = 0; c < VC_NODE_CAMS; c++) vc_bgmodel_set_params(n->bg[c], &n->sub);
    n->state = VC_STATE_READY;
  } else {
    free_models(n);
    n->state = VC_STATE_CONFIGURED;
  }
  double unseen = vc_carver_unseen_fraction(carver);
  if (unseen > 0 && warning && warning_len)
    snprintf(warning, warning_len, "%.1f %% of the voxel grid is not seen by both cameras of node %u",
             unseen * 100.0, n->id);
  return 0;
}

int vc_node_background_begin(vc_node* n, uint32_t frames) {
  if (!n->have_cfg) return -EAGAIN;
  if (frames == 0) frames = n->cfg.background_frames;
  if (frames < 2) frames = 2;
  free_models(n);
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    int rc = vc_bgmodel_new(n->cams[c].width, n->cams[c].height, &n->bg[c], NULL, 0);
    if (rc < 0) {
      free_models(n);
      n->state = VC_STATE_CONFIGURED;
      return rc;
    }
  }
  n->bg_wanted = frames;
  n->bg_have = 0;
  n->state = VC_STATE_BACKGROUND;
  return 0;
}

int vc_node_background_add(vc_node* n, const uint8_t* const rgb[VC_NODE_CAMS],
                           const size_t stride[VC_NODE_CAMS]) {
  if (n->state != VC_STATE_BACKGROUND) return -EAGAIN;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    int rc = vc_bgmodel_learn(n->bg[c], rgb[c], stride[c]);
    if (rc < 0) return rc;
  }
  if (++n->bg_have < n->bg_wanted) return 0;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    int rc = vc_bgmodel_finish(n->bg[c]);
    if (rc == 0) rc = vc_bgmodel_set_params(n->bg[c], &n->sub);
    if (rc < 0) {
      free_models(n);
      n->state = VC_STATE_CONFIGURED;
      return rc;
    }
  }
  n->bg_learnt = true;
  n->state = VC_STATE_READY;
  return 1;
}

#define BG_MAGIC 0x47424356u /* "VCBG" */

static void put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}
static uint32_t get_u32(const uint8_t* p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

int vc_node_save_background(const vc_node* n, const char* dir) {
  if (!n->bg_learnt) return -EAGAIN;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    size_t px = (size_t)n->cams[c].width * (size_t)n->cams[c].height * 3;
    size_t len = 24 + px + 2 * px;
    uint8_t* buf = malloc(len);
    if (!buf) return -ENOMEM;
    memcpy(buf + 24, vc_bgmodel_mean(n->bg[c]), px);
    const uint16_t* sg = vc_bgmodel_sigma_q8(n->bg[c]);
    for (size_t i = 0; i < px; i++) {
      buf[24 + px + 2 * i] = (uint8_t)sg[i];
      buf[24 + px + 2 * i + 1] = (uint8_t)(sg[i] >> 8);
    }
    put_u32(buf, BG_MAGIC);
    put_u32(buf + 4, 1);
    put_u32(buf + 8, (uint32_t)n->cams[c].width);
    put_u32(buf + 12, (uint32_t)n->cams[c].height);
    put_u32(buf + 16, (uint32_t)vc_bgmodel_frames(n->bg[c]));
    put_u32(buf + 20, vc_crc32c(0, buf + 24, len - 24));
    char path[4096], tmp[4200];
    snprintf(path, sizeof(path), "%s/background-cam%d.vcbg", dir, c);
    snprintf(tmp, sizeof(tmp), "%s.tmp", path);
    FILE* f = fopen(tmp, "wb");
    int rc = 0;
    if (!f || fwrite(buf, 1, len, f) != len) rc = -EIO;
    if (f && fclose(f) != 0) rc = -EIO;
    if (rc == 0 && rename(tmp, path) != 0) rc = -errno; /* atomic: a crash leaves the old file */
    free(buf);
    if (rc < 0) return rc;
  }
  return 0;
}

int vc_node_load_background(vc_node* n, const char* dir, char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  vc_bgmodel* models[VC_NODE_CAMS] = {NULL, NULL};
  uint8_t* buf = NULL;
  int rc = 0;
  for (int c = 0; c < VC_NODE_CAMS && rc == 0; c++) {
    char path[4096];
    snprintf(path, sizeof(path), "%s/background-cam%d.vcbg", dir, c);
    FILE* f = fopen(path, "rb");
    if (!f) {
      rc = errno == ENOENT ? -ENOENT : -errno;
      vc_why(why, why_len, "%s: %s", path, strerror(errno));
      break;
    }
    size_t px = (size_t)n->cams[c].width * (size_t)n->cams[c].height * 3;
    size_t len = 24 + 3 * px;
    buf = malloc(len + 1);
    size_t got = buf ? fread(buf, 1, len + 1, f) : 0;
    fclose(f);
    if (!buf) {
      rc = -ENOMEM;
      break;
    }
    if (got < 24 || get_u32(buf) != BG_MAGIC || get_u32(buf + 4) != 1) {
      vc_why(why, why_len, "%s: not a background model", path);
      rc = -EINVAL;
    } else if ((int)get_u32(buf + 8) != n->cams[c].width || (int)get_u32(buf + 12) != n->cams[c].height ||
               got != len) {
      vc_why(why, why_len, "%s: learnt at %ux%u, camera %d delivers %dx%d", path, get_u32(buf + 8),
             get_u32(buf + 12), c, n->cams[c].width, n->cams[c].height);
      rc = -EINVAL;
    } else if (vc_crc32c(0, buf + 24, len - 24) != get_u32(buf + 20)) {
      vc_why(why, why_len, "%s: checksum mismatch (corrupt file)", path);
      rc = -EINVAL;
    } else {
      uint16_t* sg = malloc(px * sizeof(uint16_t));
      char bad[160] = "out of memory";
      rc = sg ? vc_bgmodel_new(n->cams[c].width, n->cams[c].height, &models[c], bad, sizeof(bad)) : -ENOMEM;
      if (rc < 0) {
        vc_why(why, why_len, "%s: %s", path, bad);
      } else {
        for (size_t i = 0; i < px; i++)
          sg[i] = (uint16_t)(buf[24 + px + 2 * i] | buf[24 + px + 2 * i + 1] << 8);
        rc = vc_bgmodel_restore(models[c], buf + 24, sg, (int)get_u32(buf + 16));
      }
      free(sg);
    }
    free(buf);
    buf = NULL;
  }
  if (rc < 0) {
    for (int c = 0; c < VC_NODE_CAMS; c++) vc_bgmodel_free(models[c]);
    return rc;
  }
  free_models(n);
  for (int c = 0; c < VC_NODE_CAMS; c++) n->bg[c] = models[c];
  n->bg_learnt = true;
  if (n->have_cfg) {
    for (int c = 0; c < VC_NODE_CAMS; c++) vc_bgmodel_set_params(n->bg[c], &n->sub);
    n->state = VC_STATE_READY;
  }
  return 0;
}

int vc_node_start(vc_node* n, uint64_t first_seq) {
  if (n->state != VC_STATE_READY && n->state != VC_STATE_RUNNING) return -EAGAIN;
  n->first_seq = first_seq;
  n->state = VC_STATE_RUNNING;
  n->grab.every = 0; /* START ends a GRAB */
  if (n->producer.reset) n->producer.reset(n->producer.user);
  return 0;
}

void vc_node_stop(vc_node* n) {
  if (n->state == VC_STATE_RUNNING) n->state = VC_STATE_READY;
  n->grab.every = 0;
}

int vc_node_grab(vc_node* n, const vc_grab* g, uint64_t first_seq, char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  if (n->state != VC_STATE_RUNNING) {
    vc_why(why, why_len, "GRAB while the node is %s, not running", vc_node_state_name(n->state));
    return -EAGAIN;
  }
  if (g->every == 0) {
    n->grab.every = 0;
    return 0;
  }
  const unsigned ch = vc_frame_format_channels(g->format);
  uint16_t cams = 0;
  int rc = 0;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    if (!(g->cameras & (1u << c))) continue;
    const size_t need = VC_PROTO_HEADER_SIZE + 12 + (size_t)n->cams[c].width * (size_t)n->cams[c].height * ch;
    if (need - VC_PROTO_HEADER_SIZE > VC_PROTO_MAX_PAYLOAD - 36) { /* 36: FRAME's fixed part + a MAC */
      vc_why(why, why_len, "camera %d's %dx%d %s image does not fit a message", c, n->cams[c].width,
             n->cams[c].height, vc_frame_format_name(g->format));
      rc = -EMSGSIZE;
      continue;
    }
    if (n->framecap[c] < need) {
      uint8_t* b = realloc(n->framebuf[c], need);
      if (!b) {
        vc_why(why, why_len, "GRAB: out of memory for camera %d's %zu-byte FRAME", c, need);
        return -ENOMEM;
      }
      n->framebuf[c] = b;
      n->framecap[c] = need;
    }
    cams = (uint16_t)(cams | (1u << c));
  }
  if ((g->cameras >> VC_NODE_CAMS) && rc == 0) {
    vc_why(why, why_len, "GRAB asks for cameras 0x%04x, the node has %d", g->cameras, VC_NODE_CAMS);
    rc = -ENODEV;
  }
  if (!cams) return rc ? rc : -ENODEV;
  n->grab = *g;
  n->grab.cameras = cams;
  n->grab_first_seq = first_seq;
  n->grab_sent = 0;
  return rc;
}

bool vc_node_grabbing(const vc_node* n) {
  return n->grab.every != 0;
}

int vc_node_frames(vc_node* n, uint64_t seq, uint64_t t_trigger_ns, const uint8_t* const rgb[VC_NODE_CAMS],
                   const size_t stride[VC_NODE_CAMS], vc_node_output* out) {
  out->count = 0;
  const vc_grab* g = &n->grab;
  if (g->every == 0 || n->state != VC_STATE_RUNNING || seq < n->grab_first_seq || seq % g->every) return 0;
  vc_header hdr = {.node_id = n->id, .seq = seq, .t_trigger_ns = t_trigger_ns};
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    if (!(g->cameras & (1u << c))) continue;
    size_t len = 0;
    if (vc_encode_frame_rgb(n->framebuf[c], n->framecap[c], &len, &hdr, (uint16_t)c, g->format,
                            (uint16_t)n->cams[c].width, (uint16_t)n->cams[c].height, rgb[c], stride[c]) < 0)
      continue; /* sizes were checked at GRAB: not reached */
    out->msg[out->count] = n->framebuf[c];
    out->len[out->count] = len;
    out->type[out->count] = VC_MSG_FRAME;
    out->count++;
    n->counters.frames_encoded++;
  }
  if (g->count && ++n->grab_sent >= g->count) n->grab.every = 0;
  return out->count;
}

void vc_node_set_features_producer(vc_node* n, const vc_features_producer* producer) {
  if (producer)
    n->producer = *producer;
  else
    memset(&n->producer, 0, sizeof(n->producer));
}

/* FEATURES of this frame into out after the HULL; a failing producer costs only these. */
static void produce_features(vc_node* n, uint64_t seq, uint64_t t_trigger_ns,
                             const uint8_t* const rgb[VC_NODE_CAMS], const size_t stride[VC_NODE_CAMS],
                             vc_node_output* out) {
  vc_features feats[VC_NODE_CAMS];
  memset(feats, 0, sizeof(feats));
  /* The tracker gets the silhouette without the limb-scale cue (bgmodel.h: VC_MASK_GROWN), the carver
   * and the SILHOUETTEs the grown one; a frame the cue left alone needs no copy. */
  const uint8_t* masks[VC_NODE_CAMS];
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    masks[c] = n->masks[c];
    if (n->grown[c] > 0 && n->track_masks[c] != NULL) {
      vc_mask_ungrown(n->masks[c], (size_t)n->cams[c].width * (size_t)n->cams[c].height, n->track_masks[c]);
      masks[c] = n->track_masks[c];
    }
  }
  int k = n->producer.track(n->producer.user, seq, rgb, stride, masks, n->cams, feats);
  if (k < 0 || k > VC_NODE_CAMS) {
    n->counters.features_failed++;
    return;
  }
  vc_header hdr = {.node_id = n->id, .seq = seq, .t_trigger_ns = t_trigger_ns};
  int first = out->count;
  for (int c = 0; c < k; c++) {
    size_t len = 0;
    if (vc_encode_features(n->featbuf[c], sizeof(n->featbuf[c]), &len, &hdr, &feats[c]) < 0) {
      out->count = first; /* all of the frame's FEATURES or none */
      n->counters.features_failed++;
      return;
    }
    out->msg[out->count] = n->featbuf[c];
    out->len[out->count] = len;
    out->type[out->count] = VC_MSG_FEATURES;
    out->count++;
  }
  n->counters.features_encoded += (uint64_t)k;
}

/* Packs a 0/255 mask of w x h bytes into a bitset of ceil(w/s) x ceil(h/s) bits (pixel x + sw*y,
 * LSB-first): a scaled pixel is set when any pixel of its s x s block is. Integer only, no division
 * per pixel, no allocation. */
static void pack_mask(const uint8_t* mask, int w, int h, int s, uint8_t* bits, int sw, int sh) {
  memset(bits, 0, ((size_t)sw * (size_t)sh + 7) / 8);
  for (int y = 0, sy = 0, ky = 0; y < h; y++) {
    const uint8_t* row = mask + (size_t)y * (size_t)w;
    size_t b = (size_t)sy * (size_t)sw; /* bit of scaled pixel (sx, sy) */
    for (int x = 0, kx = 0; x < w; x++) {
      if (row[x]) bits[b >> 3] = (uint8_t)(bits[b >> 3] | (1u << (b & 7)));
      if (++kx == s) {
        kx = 0;
        b++;
      }
    }
    if (++ky == s) {
      ky = 0;
      sy++;
    }
  }
}

/* The SILHOUETTEs of this frame into out, after its FEATURES and before its HULL. */
static void produce_silhouettes(vc_node* n, uint64_t seq, uint64_t t_trigger_ns, vc_node_output* out) {
  vc_header hdr = {.node_id = n->id, .seq = seq, .t_trigger_ns = t_trigger_ns};
  const int s = n->cfg.silhouette_scale;
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    pack_mask(n->masks[c], n->cams[c].width, n->cams[c].height, s, n->silbits[c], n->silw[c], n->silh[c]);
    size_t len = 0;
    int rc = vc_encode_silhouette_bits(n->silbuf[c], n->silcap[c], &len, &hdr, (uint16_t)c, (uint16_t)s,
                                       n->silw[c], n->silh[c], n->silbits[c]);
    if (rc < 0) { /* more runs or bytes than a message may hold: this camera's is not sent */
      n->counters.silhouettes_over_limit++;
      continue;
    }
    out->msg[out->count] = n->silbuf[c];
    out->len[out->count] = len;
    out->type[out->count] = VC_MSG_SILHOUETTE;
    out->count++;
    n->counters.silhouettes_encoded++;
  }
}

int vc_node_process(vc_node* n, uint64_t seq, uint64_t t_trigger_ns, const uint8_t* const rgb[VC_NODE_CAMS],
                    const size_t stride[VC_NODE_CAMS], const uint8_t** msg, size_t* len) {
  vc_node_output out;
  int rc = vc_node_process_frame(n, seq, t_trigger_ns, rgb, stride, &out);
  if (rc == 0) { /* the HULL is the last message of a frame */
    *msg = out.msg[out.count - 1];
    *len = out.len[out.count - 1];
  }
  return rc;
}

int vc_node_process_frame(vc_node* n, uint64_t seq, uint64_t t_trigger_ns,
                          const uint8_t* const rgb[VC_NODE_CAMS], const size_t stride[VC_NODE_CAMS],
                          vc_node_output* out) {
  out->count = 0;
  if (n->state != VC_STATE_RUNNING) return -EAGAIN;
  if (seq < n->first_seq) return 1;
  uint64_t t0 = now_ns();
  for (int c = 0; c < VC_NODE_CAMS; c++) {
    int rc = vc_subtract(n->bg[c], rgb[c], stride[c], n->masks[c], NULL);
    if (rc < 0) return rc;
  }
  uint64_t t1 = now_ns();
  for (int c = 0; c < VC_NODE_CAMS; c++) { /* vc_mask_frame's second half: the clean-up, then the cue */
    int rc = vc_cleanup_grow(n->bg[c], rgb[c], stride[c], n->masks[c], n->cleanup_radius, n->scratch,
                             n->scratch_len, &n->grown[c]);
    if (rc < 0) return rc;
  }
  uint64_t t2 = now_ns();
  int rc = vc_carver_run(n->carver, n->masks[0], n->masks[1], n->bitset, NULL);
  if (rc < 0) return rc;
  n->have_frame = true;
  uint64_t t3 = now_ns();
  vc_header hdr = {.node_id = n->id, .seq = seq, .t_trigger_ns = t_trigger_ns};
  size_t hull_len = 0;
  rc = vc_encode_hull_bits(n->msgbuf, n->msgcap, &hull_len, &hdr, n->cfg.grid_id, n->bitset,
                           (size_t)vc_carver_voxels(n->carver));
  uint64_t t4 = now_ns();
  stage_add(n, ST_SUBTRACT, t0, t1);
  stage_add(n, ST_CLEANUP, t1, t2);
  stage_add(n, ST_CARVE, t2, t3);
  stage_add(n, ST_ENCODE, t3, t4);
  n->stage_frames++;
  n->counters.frames_processed++;
  if (rc < 0) {
    if (rc == VC_PROTO_ELIMIT) n->counters.hulls_over_limit++;
    return rc;
  }
  n->counters.hulls_encoded++;
  /* The frame's FEATURES and SILHOUETTEs first, its HULL last: the host resolves a frame when the last
   * node's HULL arrives, so anything a node sends for the frame after its HULL could come too late. */
  if (n->producer.track && n->cfg.feature_role == VC_ROLE_FRONT)
    produce_features(n, seq, t_trigger_ns, rgb, stride, out);
  if (n->cfg.silhouette_every && seq % n->cfg.silhouette_every == 0)
    produce_silhouettes(n, seq, t_trigger_ns, out);
  out->msg[out->count] = n->msgbuf;
  out->len[out->count] = hull_len;
  out->type[out->count] = VC_MSG_HULL;
  out->count++;
  return 0;
}

const uint8_t* vc_node_mask(const vc_node* n, int cam) {
  if (!n->have_frame || cam < 0 || cam >= VC_NODE_CAMS) return NULL;
  return n->masks[cam];
}

const uint8_t* vc_node_bitset(const vc_node* n, uint64_t* voxels) {
  if (!n->have_frame) {
    if (voxels) *voxels = 0;
    return NULL;
  }
  if (voxels) *voxels = vc_carver_voxels(n->carver);
  return n->bitset;
}

uint32_t vc_node_state(const vc_node* n) {
  return n->state;
}
uint16_t vc_node_id(const vc_node* n) {
  return n->id;
}
uint64_t vc_node_first_seq(const vc_node* n) {
  return n->first_seq;
}

void vc_node_get_counters(const vc_node* n, vc_node_counters* out) {
  *out = n->counters;
}

int vc_node_take_stage_times(vc_node* n, vc_stage_time* stages, int max_stages, uint32_t* frames) {
  int k = 0;
  *frames = n->stage_frames;
  for (int s = 0; s < ST_COUNT && k < max_stages; s++) {
    if (n->stage_frames == 0) break;
    uint64_t mean = n->stages[s].sum_ns / n->stage_frames;
    stages[k].stage_id = stage_ids[s];
    stages[k].mean_ns = mean > UINT32_MAX ? UINT32_MAX : (uint32_t)mean;
    stages[k].max_ns = n->stages[s].max_ns > UINT32_MAX ? UINT32_MAX : (uint32_t)n->stages[s].max_ns;
    k++;
  }
  memset(n->stages, 0, sizeof(n->stages));
  n->stage_frames = 0;
  return k;
}
