/* The "v4l2" camera backend: a V4L2 single-planar capture node, mmap streaming.
 *
 * open: QUERYCAP (capture + streaming), ENUM_FMT (the requested format must be offered, else a clear
 * error listing what is), S_FMT (the driver may not change the format or a requested size: a mocap
 * camera's size is tied to its calibration), S_PARM (frame interval), the configured controls (by id
 * or by v4l2-ctl style name — the hook for a sensor's external-trigger mode), REQBUFS + mmap.
 * capture: poll() with the caller's timeout (none → "camera stopped delivering"), DQBUF, skip frames
 * the driver flags as corrupt, convert to RGB24 in fixed point (pixconv.h) with the colorimetry the
 * driver reports, requeue. Timestamps: V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC buffers carry CLOCK_MONOTONIC
 * already; a driver that gives none (UNKNOWN/COPY) gets the dequeue time, flagged VC_FRAME_TS_DEQUEUE.
 * The 32-bit driver sequence is widened to 64 bits across wraps.
 * Limits: no multi-planar or compressed formats, no USERPTR/DMABUF import, interlaced rejected.
 */
#define _GNU_SOURCE
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "v4l2_util.h"
#include "voxcap/edge/camera_backend.h"
#include "voxcap/edge/clock.h"
#include "voxcap/edge/pixconv.h"

#define MAX_BUFFERS 32

struct v4l2_buf {
  void* start;
  size_t length;
};

struct v4l2_priv {
  int fd;
  struct v4l2_buf bufs[MAX_BUFFERS];
  unsigned nbufs;
  vc_pixfmt fmt;
  int width, height;
  uint32_t bytesperline;
  uint32_t frame_bytes; /* bytes a complete frame occupies */
  vc_yuv_coeffs yuv;
  bool streaming;
  bool have_seq;
  uint32_t last_seq32;
  uint64_t seq_hi;
};

static int xioctl(int fd, unsigned long req, void* arg) {
  int r;
  do r = ioctl(fd, req, arg);
  while (r == -1 && errno == EINTR);
  return r;
}

static void priv_free(void* p) {
  struct v4l2_priv* v = p;
  if (!v) return;
  for (unsigned i = 0; i < v->nbufs; i++)
    if (v->bufs[i].start && v->bufs[i].start != MAP_FAILED) munmap(v->bufs[i].start, v->bufs[i].length);
  if (v->fd >= 0) {
    if (v->nbufs) {
      struct v4l2_requestbuffers req = {
          .count = 0, .type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
      (void)xioctl(v->fd, VIDIOC_REQBUFS, &req);
    }
    close(v->fd);
  }
  free(v);
}

/* Finds a control by id or v4l2-ctl style name; fills *q. 0 or -ENOENT. */
static int find_control(int fd, const vc_camera_control* c, struct v4l2_query_ext_ctrl* q) {
  if (!c->name) {
    memset(q, 0, sizeof *q);
    q->id = c->id;
    return xioctl(fd, VIDIOC_QUERY_EXT_CTRL, q) == 0 ? 0 : -ENOENT;
  }
  char want[64];
  vc_v4l2_control_key(c->name, want, sizeof want);
  memset(q, 0, sizeof *q);
  q->id = V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
  while (xioctl(fd, VIDIOC_QUERY_EXT_CTRL, q) == 0) {
    char key[64];
    if (!(q->flags & V4L2_CTRL_FLAG_DISABLED) && q->type != V4L2_CTRL_TYPE_CTRL_CLASS) {
      vc_v4l2_control_key(q->name, key, sizeof key);
      if (strcmp(key, want) == 0) return 0;
    }
    q->id |= V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND;
  }
  return -ENOENT;
}

static int apply_controls(vc_camera* cam, int fd, const vc_camera_config* cfg) {
  for (size_t i = 0; i < cfg->n_controls; i++) {
    const vc_camera_control* c = &cfg->controls[i];
    struct v4l2_query_ext_ctrl q;
    char label[80];
    if (c->name)
      snprintf(label, sizeof label, "'%s'", c->name);
    else
      snprintf(label, sizeof label, "0x%08x", c->id);
    if (find_control(fd, c, &q) != 0) return vc_camera_set_error(cam, -ENOENT, "no control %s", label);
    if (q.flags & V4L2_CTRL_FLAG_READ_ONLY)
      return vc_camera_set_error(cam, -EACCES, "control %s is read-only", label);
    if (q.type == V4L2_CTRL_TYPE_BUTTON) {
      struct v4l2_control one = {.id = q.id, .value = 0};
      if (xioctl(fd, VIDIOC_S_CTRL, &one) != 0)
        return vc_camera_set_error(cam, -errno, "pressing control %s failed: %s", label, strerror(errno));
      continue;
    }
    if (q.type != V4L2_CTRL_TYPE_INTEGER && q.type != V4L2_CTRL_TYPE_BOOLEAN &&
        q.type != V4L2_CTRL_TYPE_MENU && q.type != V4L2_CTRL_TYPE_INTEGER_MENU &&
        q.type != V4L2_CTRL_TYPE_INTEGER64 && q.type != V4L2_CTRL_TYPE_BITMASK)
      return vc_camera_set_error(cam, -ENOTSUP, "control %s has a type this hook cannot set", label);
    if (c->value < q.minimum || c->value > q.maximum)
      return vc_camera_set_error(cam, -ERANGE, "control %s = %lld out of range [%lld, %lld]", label,
                                 (long long)c->value, (long long)q.minimum, (long long)q.maximum);
    struct v4l2_ext_control ec = {.id = q.id};
    if (q.type == V4L2_CTRL_TYPE_INTEGER64)
      ec.value64 = c->value;
    else
      ec.value = (int32_t)c->value;
    struct v4l2_ext_controls ecs = {.which = V4L2_CTRL_WHICH_CUR_VAL, .count = 1, .controls = &ec};
    if (xioctl(fd, VIDIOC_S_EXT_CTRLS, &ecs) != 0)
      return vc_camera_set_error(cam, -errno, "setting control %s = %lld failed: %s", label,
                                 (long long)c->value, strerror(errno));
  }
  return 0;
}

static int v4l2_open(vc_camera* cam, const vc_camera_config* cfg, vc_camera_info* info, void** out) {
  struct v4l2_priv* v;
  struct v4l2_capability cap;
  struct stat st;
  int rc;
  const char* dev = cfg->device;
  *out = NULL;
  if (!dev || !dev[0]) return vc_camera_set_error(cam, -EINVAL, "no device given (e.g. /dev/video0)");

  v = calloc(1, sizeof *v);
  if (!v) return vc_camera_set_error(cam, -ENOMEM, "out of memory");
  v->fd = open(dev, O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (v->fd < 0) {
    rc = vc_camera_set_error(cam, -errno, "cannot open: %s", strerror(errno));
    goto err;
  }
  if (fstat(v->fd, &st) != 0 || !S_ISCHR(st.st_mode)) {
    rc = vc_camera_set_error(cam, -ENODEV, "not a V4L2 device (not a character device)");
    goto err;
  }
  memset(&cap, 0, sizeof cap);
  if (xioctl(v->fd, VIDIOC_QUERYCAP, &cap) != 0) {
    rc = vc_camera_set_error(cam, -ENODEV, "not a V4L2 device (VIDIOC_QUERYCAP: %s)", strerror(errno));
    goto err;
  }
  uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE)) {
    rc = vc_camera_set_error(cam, -ENOTSUP, "%s",
                             (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE)
                                 ? "multi-planar capture devices are not supported"
                                 : "not a video capture device");
    goto err;
  }
  if (!(caps & V4L2_CAP_STREAMING)) {
    rc = vc_camera_set_error(cam, -ENOTSUP, "device has no streaming I/O");
    goto err;
  }
  snprintf(info->driver, sizeof info->driver, "%.24s/%.32s", (const char*)cap.driver, (const char*)cap.card);

  /* the requested format must be one the device offers */
  vc_pixfmt want = cfg->pixfmt == VC_PIXFMT_DEFAULT ? VC_PIXFMT_YUYV : cfg->pixfmt;
  uint32_t fourcc = vc_v4l2_fourcc_from_pixfmt(want);
  uint32_t offered[64];
  size_t noffered = 0;
  for (struct v4l2_fmtdesc fd = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
       noffered < 64 && xioctl(v->fd, VIDIOC_ENUM_FMT, &fd) == 0; fd.index++)
    offered[noffered++] = fd.pixelformat;
  if (!vc_v4l2_format_offered(fourcc, offered, noffered)) {
    char list[256];
    vc_v4l2_format_list(offered, noffered, list, sizeof list);
    rc = vc_camera_set_error(cam, -ENOTSUP, "format %s not supported (device offers: %s)",
                             vc_pixfmt_name(want), list);
    goto err;
  }

  struct v4l2_format f = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
  if (xioctl(v->fd, VIDIOC_G_FMT, &f) != 0) {
    rc = vc_camera_set_error(cam, -errno, "VIDIOC_G_FMT: %s", strerror(errno));
    goto err;
  }
  if (cfg->width > 0) {
    f.fmt.pix.width = (uint32_t)cfg->width;
    f.fmt.pix.height = (uint32_t)cfg->height;
  }
  f.fmt.pix.pixelformat = fourcc;
  f.fmt.pix.field = V4L2_FIELD_NONE;
  f.fmt.pix.bytesperline = 0;
  if (xioctl(v->fd, VIDIOC_S_FMT, &f) != 0) {
    rc = vc_camera_set_error(cam, errno == EBUSY ? -EBUSY : -ENOTSUP, "VIDIOC_S_FMT %s %dx%d: %s",
                             vc_pixfmt_name(want), cfg->width, cfg->height, strerror(errno));
    goto err;
  }
  if (f.fmt.pix.pixelformat != fourcc) {
    rc = vc_camera_set_error(cam, -ENOTSUP, "format %s not supported (driver chose another)",
                             vc_pixfmt_name(want));
    goto err;
  }
  if (cfg->width > 0 && ((int)f.fmt.pix.width != cfg->width || (int)f.fmt.pix.height != cfg->height)) {
    rc =
        vc_camera_set_error(cam, -ENOTSUP, "size %dx%d not supported for %s (driver offers %ux%u)",
                            cfg->width, cfg->height, vc_pixfmt_name(want), f.fmt.pix.width, f.fmt.pix.height);
    goto err;
  }
  if (f.fmt.pix.field != V4L2_FIELD_NONE && f.fmt.pix.field != V4L2_FIELD_ANY) {
    rc = vc_camera_set_error(cam, -ENOTSUP, "interlaced video (field %u) is not supported", f.fmt.pix.field);
    goto err;
  }
  v->fmt = want;
  v->width = (int)f.fmt.pix.width;
  v->height = (int)f.fmt.pix.height;
  uint32_t min_bpl = vc_pixfmt_bytes_per_pixel(want) * f.fmt.pix.width;
  if (want == VC_PIXFMT_YUYV || want == VC_PIXFMT_UYVY) min_bpl = (f.fmt.pix.width + 1) / 2 * 4;
  v->bytesperline = f.fmt.pix.bytesperline >= min_bpl ? f.fmt.pix.bytesperline : min_bpl;
  v->frame_bytes = v->bytesperline * (f.fmt.pix.height - 1) + min_bpl;
  {
    vc_yuv_matrix m;
    bool full;
    vc_v4l2_colorimetry(f.fmt.pix.colorspace, f.fmt.pix.ycbcr_enc, f.fmt.pix.quantization, &m, &full);
    vc_yuv_coeffs_init(&v->yuv, m, full);
  }

  /* frame interval */
  struct v4l2_streamparm parm = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE};
  if (cfg->fps_num) {
    uint32_t den = cfg->fps_den ? cfg->fps_den : 1;
    if (xioctl(v->fd, VIDIOC_G_PARM, &parm) != 0 || !(parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
      rc = vc_camera_set_error(cam, -ENOTSUP, "the frame rate cannot be set on this device");
      goto err;
    }
    parm.parm.capture.timeperframe.numerator = den;
    parm.parm.capture.timeperframe.denominator = cfg->fps_num;
    if (xioctl(v->fd, VIDIOC_S_PARM, &parm) != 0) {
      rc =
          vc_camera_set_error(cam, -errno, "VIDIOC_S_PARM %u/%u fps: %s", cfg->fps_num, den, strerror(errno));
      goto err;
    }
  }
  memset(&parm, 0, sizeof parm);
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(v->fd, VIDIOC_G_PARM, &parm) == 0 && parm.parm.capture.timeperframe.numerator) {
    info->fps_num = parm.parm.capture.timeperframe.denominator;
    info->fps_den = parm.parm.capture.timeperframe.numerator;
  }

  rc = apply_controls(cam, v->fd, cfg);
  if (rc) goto err;

  /* buffers */
  struct v4l2_requestbuffers req = {.count = cfg->buffers ? cfg->buffers : 4,
                                    .type = V4L2_BUF_TYPE_VIDEO_CAPTURE,
                                    .memory = V4L2_MEMORY_MMAP};
  if (req.count > MAX_BUFFERS) req.count = MAX_BUFFERS;
  if (xioctl(v->fd, VIDIOC_REQBUFS, &req) != 0) {
    rc = vc_camera_set_error(cam, errno == EBUSY ? -EBUSY : -EIO, "VIDIOC_REQBUFS (mmap): %s%s",
                             strerror(errno), errno == EBUSY ? " (device in use?)" : "");
    goto err;
  }
  if (req.count < 2) {
    rc = vc_camera_set_error(cam, -ENOMEM, "driver granted %u buffers, need at least 2", req.count);
    goto err;
  }
  if (req.count > MAX_BUFFERS) req.count = MAX_BUFFERS;
  for (unsigned i = 0; i < req.count; i++) {
    struct v4l2_buffer b = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP, .index = i};
    if (xioctl(v->fd, VIDIOC_QUERYBUF, &b) != 0) {
      rc = vc_camera_set_error(cam, -EIO, "VIDIOC_QUERYBUF %u: %s", i, strerror(errno));
      goto err;
    }
    v->bufs[i].length = b.length;
    v->bufs[i].start = mmap(NULL, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, v->fd, b.m.offset);
    v->nbufs = i + 1;
    if (v->bufs[i].start == MAP_FAILED) {
      rc = vc_camera_set_error(cam, -errno, "mmap of buffer %u: %s", i, strerror(errno));
      goto err;
    }
    if (b.length < v->frame_bytes) {
      rc = vc_camera_set_error(cam, -EIO, "buffer %u holds %u bytes, a frame needs %u", i, b.length,
                               v->frame_bytes);
      goto err;
    }
  }
  info->width = v->width;
  info->height = v->height;
  info->pixfmt = v->fmt;
  info->buffers = v->nbufs;
  *out = v;
  return 0;

err:
  priv_free(v);
  return rc;
}

static int v4l2_start(vc_camera* cam, void* p) {
  struct v4l2_priv* v = p;
  for (unsigned i = 0; i < v->nbufs; i++) {
    struct v4l2_buffer b = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP, .index = i};
    if (xioctl(v->fd, VIDIOC_QBUF, &b) != 0)
      return vc_camera_set_error(cam, errno == ENODEV ? -ENODEV : -EIO, "VIDIOC_QBUF %u: %s", i,
                                 strerror(errno));
  }
  enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(v->fd, VIDIOC_STREAMON, &type) != 0)
    return vc_camera_set_error(cam, errno == ENODEV ? -ENODEV : -EIO, "VIDIOC_STREAMON: %s", strerror(errno));
  v->streaming = true;
  v->have_seq = false;
  v->seq_hi = 0;
  return 0;
}

static int v4l2_stop(vc_camera* cam, void* p) {
  struct v4l2_priv* v = p;
  enum v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (!v->streaming) return 0;
  v->streaming = false;
  /* STREAMOFF also dequeues every buffer; a vanished device has nothing left to stop */
  if (xioctl(v->fd, VIDIOC_STREAMOFF, &type) != 0 && errno != ENODEV)
    return vc_camera_set_error(cam, -EIO, "VIDIOC_STREAMOFF: %s", strerror(errno));
  return 0;
}

static int v4l2_capture(vc_camera* cam, void* p, int timeout_ms, uint8_t* rgb, size_t stride,
                        vc_frame* meta) {
  struct v4l2_priv* v = p;
  uint64_t deadline = timeout_ms >= 0 ? vc_clock_monotonic_ns() + (uint64_t)timeout_ms * 1000000ull : 0;
  for (;;) {
    int wait_ms = -1;
    if (timeout_ms >= 0) {
      uint64_t now = vc_clock_monotonic_ns();
      wait_ms = now >= deadline ? 0 : (int)((deadline - now + 999999) / 1000000);
    }
    struct pollfd pfd = {.fd = v->fd, .events = POLLIN};
    int pr = poll(&pfd, 1, wait_ms);
    if (pr < 0) {
      if (errno == EINTR) continue;
      return vc_camera_set_error(cam, -errno, "poll: %s", strerror(errno));
    }
    if (pr == 0)
      return vc_camera_set_error(cam, -ETIMEDOUT, "camera stopped delivering: no frame within %d ms",
                                 timeout_ms);
    struct v4l2_buffer b = {.type = V4L2_BUF_TYPE_VIDEO_CAPTURE, .memory = V4L2_MEMORY_MMAP};
    if (xioctl(v->fd, VIDIOC_DQBUF, &b) != 0) {
      if (errno == EAGAIN) continue;
      if (errno == ENODEV) return vc_camera_set_error(cam, -ENODEV, "device disconnected");
      return vc_camera_set_error(cam, -EIO, "VIDIOC_DQBUF: %s", strerror(errno));
    }
    uint64_t t_dq = vc_clock_monotonic_ns();
    bool bad = (b.flags & V4L2_BUF_FLAG_ERROR) || b.index >= v->nbufs ||
               (b.bytesused != 0 && b.bytesused < v->frame_bytes);
    if (!bad) {
      vc_pixconv_to_rgb(v->fmt, v->bufs[b.index].start, v->bytesperline, rgb, stride, v->width, v->height,
                        &v->yuv);
      if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
          (b.timestamp.tv_sec || b.timestamp.tv_usec)) {
        meta->t_ns = (uint64_t)b.timestamp.tv_sec * 1000000000ull + (uint64_t)b.timestamp.tv_usec * 1000ull;
        meta->flags = VC_FRAME_TS_DRIVER;
      } else {
        meta->t_ns = t_dq;
        meta->flags = VC_FRAME_TS_DEQUEUE;
      }
      if (v->have_seq && b.sequence < v->last_seq32) v->seq_hi += 1ull << 32;
      v->have_seq = true;
      v->last_seq32 = b.sequence;
      meta->sequence = v->seq_hi | b.sequence;
      meta->index = meta->sequence;
    } else {
      vc_camera_count_corrupted(cam);
    }
    if (b.index < v->nbufs && xioctl(v->fd, VIDIOC_QBUF, &b) != 0)
      return vc_camera_set_error(cam, errno == ENODEV ? -ENODEV : -EIO, "VIDIOC_QBUF: %s", strerror(errno));
    if (!bad) return 0;
  }
}

const vc_camera_backend vc_camera_backend_v4l2 = {
    .name = "v4l2",
    .open = v4l2_open,
    .start = v4l2_start,
    .capture = v4l2_capture,
    .stop = v4l2_stop,
    .free_priv = priv_free,
    .soft_trigger = NULL, /* a real sensor's trigger is a wire */
    .caps = NULL,
    .rewind = NULL,
};
