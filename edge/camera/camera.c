/* The common layer behind vc_camera: state machine, held RGB buffers, statistics, errors.
 * Backends (camera_backend.h) only capture and convert. */
#define _GNU_SOURCE
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "voxcap/edge/camera_backend.h"
#include "voxcap/why.h"

#define VC_CAMERA_MAX_HELD 16

enum cam_state { CAM_OPENING, CAM_OPEN, CAM_STREAMING };

struct vc_camera {
  const vc_camera_backend* be;
  void* priv;
  const void* arg; /* vc_camera_open_backend_arg's, during open only */
  enum cam_state state;
  vc_camera_info info;
  vc_camera_stats stats;
  char device[128];
  int err;
  char errmsg[640];
  /* held frame buffers */
  unsigned nslots;
  size_t stride;
  uint8_t* slot_mem[VC_CAMERA_MAX_HELD];
  bool slot_held[VC_CAMERA_MAX_HELD];
  /* sequence-gap tracking */
  bool have_seq;
  uint64_t last_seq;
};

static const char* const pixfmt_names[] = {"default", "rgb24", "bgr24", "yuyv", "uyvy", "grey"};

const char* vc_pixfmt_name(vc_pixfmt fmt) {
  if ((unsigned)fmt >= sizeof pixfmt_names / sizeof pixfmt_names[0]) return NULL;
  return pixfmt_names[fmt];
}

int vc_pixfmt_from_name(const char* name, vc_pixfmt* out) {
  if (!name || !out) return -EINVAL;
  if (strcasecmp(name, "gray") == 0) {
    *out = VC_PIXFMT_GREY;
    return 0;
  }
  for (unsigned i = 0; i < sizeof pixfmt_names / sizeof pixfmt_names[0]; i++) {
    if (strcasecmp(name, pixfmt_names[i]) == 0) {
      *out = (vc_pixfmt)i;
      return 0;
    }
  }
  return -EINVAL;
}

void vc_camera_config_init(vc_camera_config* cfg) {
  memset(cfg, 0, sizeof *cfg);
  cfg->fps_den = 1;
}

int vc_camera_set_verror(vc_camera* cam, int code, const char* fmt, va_list ap) {
  char msg[384];
  vc_whyv(msg, sizeof msg, fmt, ap);
  cam->err = code;
  if (cam->device[0])
    vc_why(cam->errmsg, sizeof cam->errmsg, "%s: %s: %s", cam->be->name, cam->device, msg);
  else
    vc_why(cam->errmsg, sizeof cam->errmsg, "%s: %s", cam->be->name, msg);
  return code;
}

int vc_camera_set_error(vc_camera* cam, int code, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vc_camera_set_verror(cam, code, fmt, ap);
  va_end(ap);
  return code;
}

void vc_camera_count_corrupted(vc_camera* cam) {
  cam->stats.corrupted++;
}

static void clear_error(vc_camera* cam) {
  cam->err = 0;
  cam->errmsg[0] = '\0';
}

static void free_slots(vc_camera* cam) {
  for (unsigned i = 0; i < VC_CAMERA_MAX_HELD; i++) {
    free(cam->slot_mem[i]);
    cam->slot_mem[i] = NULL;
    cam->slot_held[i] = false;
  }
  cam->nslots = 0;
}

static int check_config(const vc_camera_config* cfg, char* why, size_t why_len) {
  const char* bad = NULL;
  if (cfg->width < 0 || cfg->height < 0 || (cfg->width == 0) != (cfg->height == 0))
    bad = "width and height must both be positive (or both 0 for the default)";
  if (!bad && cfg->held_frames > VC_CAMERA_MAX_HELD) bad = "held_frames must be at most 16";
  if (!bad && cfg->index < 0) bad = "index must be >= 0";
  if (!bad && cfg->n_controls && !cfg->controls) bad = "n_controls > 0 but controls is NULL";
  if (!bad && vc_pixfmt_name(cfg->pixfmt) == NULL) bad = "unknown pixel format";
  if (!bad) return 0;
  vc_why(why, why_len, "camera config: %s", bad);
  return -EINVAL;
}

int vc_camera_open_backend(const vc_camera_backend* backend, const vc_camera_config* cfg, vc_camera** out,
                           char* why, size_t why_len) {
  return vc_camera_open_backend_arg(backend, cfg, NULL, out, why, why_len);
}

const void* vc_camera_backend_arg(const vc_camera* cam) {
  return cam->arg;
}

int vc_camera_open_backend_arg(const vc_camera_backend* backend, const vc_camera_config* cfg, const void* arg,
                               vc_camera** out, char* why, size_t why_len) {
  int rc;
  vc_camera* cam;
  if (out) *out = NULL;
  vc_why_clear(why, why_len);
  if (!backend || !cfg || !out) {
    vc_why(why, why_len, "camera: invalid arguments");
    return -EINVAL;
  }
  rc = check_config(cfg, why, why_len);
  if (rc) return rc;

  cam = calloc(1, sizeof *cam);
  if (!cam) {
    vc_why(why, why_len, "%s: out of memory", backend->name);
    return -ENOMEM;
  }
  cam->be = backend;
  cam->state = CAM_OPENING;
  if (cfg->device) snprintf(cam->device, sizeof cam->device, "%s", cfg->device);
  cam->info.backend = backend->name;
  snprintf(cam->info.device, sizeof cam->info.device, "%s", cam->device);
  cam->info.fps_den = 1;

  cam->arg = arg;
  rc = backend->open(cam, cfg, &cam->info, &cam->priv);
  cam->arg = NULL;
  if (rc) {
    if (!cam->err) vc_camera_set_error(cam, rc, "open failed: %s", strerror(-rc));
    goto err_msg;
  }
  if (cam->info.width <= 0 || cam->info.height <= 0) {
    rc = vc_camera_set_error(cam, -EIO, "backend reported no frame size");
    goto err_backend;
  }
  cam->stride = ((size_t)cam->info.width * 3 + 15) & ~(size_t)15;
  cam->nslots = cfg->held_frames ? cfg->held_frames : 2;
  for (unsigned i = 0; i < cam->nslots; i++) {
    cam->slot_mem[i] = aligned_alloc(64, (cam->stride * (size_t)cam->info.height + 63) & ~(size_t)63);
    if (!cam->slot_mem[i]) {
      rc = vc_camera_set_error(cam, -ENOMEM, "out of memory for %u frames of %dx%d", cam->nslots,
                               cam->info.width, cam->info.height);
      goto err_backend;
    }
  }
  cam->state = CAM_OPEN;
  *out = cam;
  return 0;

err_backend:
  backend->free_priv(cam->priv);
err_msg:
  vc_why(why, why_len, "%s", cam->errmsg);
  free_slots(cam);
  free(cam);
  return rc;
}

int vc_camera_start(vc_camera* cam) {
  int rc;
  if (!cam) return -EINVAL;
  clear_error(cam);
  if (cam->state == CAM_STREAMING) return 0;
  rc = cam->be->start(cam, cam->priv);
  if (rc) {
    if (!cam->err) vc_camera_set_error(cam, rc, "start failed: %s", strerror(-rc));
    return rc;
  }
  cam->have_seq = false;
  cam->state = CAM_STREAMING;
  return 0;
}

int vc_camera_capture(vc_camera* cam, int timeout_ms, vc_frame* frame) {
  int rc, slot = -1;
  if (!cam || !frame) return -EINVAL;
  clear_error(cam);
  if (cam->state != CAM_STREAMING)
    return vc_camera_set_error(cam, -EINVAL, "capture before start (or after stop)");
  for (unsigned i = 0; i < cam->nslots; i++) {
    if (!cam->slot_held[i]) {
      slot = (int)i;
      break;
    }
  }
  if (slot < 0)
    return vc_camera_set_error(cam, -EBUSY, "all %u frame buffers are held: release frames first",
                               cam->nslots);
  memset(frame, 0, sizeof *frame);
  rc = cam->be->capture(cam, cam->priv, timeout_ms, cam->slot_mem[slot], cam->stride, frame);
  if (rc) {
    if (rc == -ETIMEDOUT) cam->stats.timeouts++;
    if (!cam->err) vc_camera_set_error(cam, rc, "capture failed: %s", strerror(-rc));
    memset(frame, 0, sizeof *frame);
    frame->slot = -1;
    return rc;
  }
  if (cam->have_seq && frame->sequence > cam->last_seq + 1)
    cam->stats.dropped += frame->sequence - cam->last_seq - 1;
  cam->have_seq = true;
  cam->last_seq = frame->sequence;
  cam->stats.frames++;
  cam->slot_held[slot] = true;
  frame->rgb = cam->slot_mem[slot];
  frame->width = cam->info.width;
  frame->height = cam->info.height;
  frame->stride = cam->stride;
  frame->slot = slot;
  return 0;
}

int vc_camera_release(vc_camera* cam, vc_frame* frame) {
  if (!cam || !frame) return -EINVAL;
  if (frame->slot < 0 || (unsigned)frame->slot >= cam->nslots || !cam->slot_held[frame->slot] ||
      frame->rgb != cam->slot_mem[frame->slot])
    return vc_camera_set_error(cam, -EINVAL, "release of a frame this camera does not hold");
  cam->slot_held[frame->slot] = false;
  frame->rgb = NULL;
  frame->slot = -1;
  return 0;
}

int vc_camera_soft_trigger(vc_camera* cam, uint64_t seq, uint64_t t_ns) {
  if (!cam) return -EINVAL;
  /* may run on another thread than capture: leaves the error state alone unless it fails */
  if (!cam->be->soft_trigger)
    return vc_camera_set_error(cam, -ENOTSUP,
                               "no software trigger: a real camera is triggered by its trigger input");
  return cam->be->soft_trigger(cam, cam->priv, seq, t_ns);
}

uint32_t vc_camera_caps(const vc_camera* cam) {
  if (!cam || !cam->be->caps) return 0;
  return cam->be->caps(cam->priv);
}

int vc_camera_rewind(vc_camera* cam, uint64_t seq_base, vc_camera_scene scene) {
  if (!cam) return -EINVAL;
  clear_error(cam);
  if (!cam->be->rewind || !(vc_camera_caps(cam) & VC_CAMERA_CAP_REWIND))
    return vc_camera_set_error(cam, -ENOTSUP, "cannot rewind: a real camera sees the room as it is");
  if (cam->state == CAM_STREAMING)
    return vc_camera_set_error(cam, -EBUSY, "rewind while streaming: stop first");
  int rc = cam->be->rewind(cam, cam->priv, seq_base, scene);
  if (rc && !cam->err) vc_camera_set_error(cam, rc, "rewind failed: %s", strerror(-rc));
  return rc;
}

int vc_camera_stop(vc_camera* cam) {
  int rc;
  if (!cam) return -EINVAL;
  clear_error(cam);
  if (cam->state != CAM_STREAMING) return 0;
  cam->state = CAM_OPEN;
  rc = cam->be->stop(cam, cam->priv);
  if (rc && !cam->err) vc_camera_set_error(cam, rc, "stop failed: %s", strerror(-rc));
  return rc;
}

void vc_camera_free(vc_camera* cam) {
  if (!cam) return;
  if (cam->state == CAM_STREAMING) (void)vc_camera_stop(cam);
  cam->be->free_priv(cam->priv);
  free_slots(cam);
  free(cam);
}

const char* vc_camera_last_error(const vc_camera* cam) {
  return cam ? cam->errmsg : "";
}
int vc_camera_last_errno(const vc_camera* cam) {
  return cam ? cam->err : 0;
}

void vc_camera_get_info(const vc_camera* cam, vc_camera_info* info) {
  if (cam && info) *info = cam->info;
}

void vc_camera_get_stats(const vc_camera* cam, vc_camera_stats* stats) {
  if (cam && stats) *stats = cam->stats;
}
