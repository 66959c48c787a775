/* vc_v4l2_vmtest: runs the edge's V4L2 camera backend against the vivid driver inside the test VM.
 *
 * Built static, without sanitizers, from the backend's own sources (camera.c, camera_v4l2.c,
 * v4l2_util.c, pixconv.c, clock.c): it is the /init payload of a busybox initramfs booted by
 * run-vm-test.sh. For each capture format (YUYV, RGB24, GREY) it sets the frame interval with S_PARM,
 * captures >= N frames and checks: the requested rate was granted, timestamps strictly increase,
 * sequence numbers never go back, frame spacing matches the rate, and vivid's 75 % colour bars come
 * out of the fixed-point conversion as the right colours at the right places (YUYV and GREY are compared with
 * the RGB24 capture of the same pattern). Then the error paths a real driver can produce: a size the
 * driver refuses, a missing device, a corrupt frame and a stalled stream (vivid's error-injection
 * controls, set through the backend's control hook), and a disconnect.
 *
 * Output: one line per check, "VCVM check=<name> result=PASS|FAIL ...", and a final
 * "VCVM-SUMMARY pass=<n> fail=<m>" that run-vm-test.sh parses. Exit status 0 iff fail == 0.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include "voxcap/edge/camera.h"
#include "voxcap/edge/camera_backend.h"
#include "v4l2_util.h"

static int g_pass, g_fail;

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static void report(const char* check, int ok, const char* fmt, ...) {
  char detail[512];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(detail, sizeof detail, fmt, ap);
  va_end(ap);
  printf("VCVM check=%s result=%s %s\n", check, ok ? "PASS" : "FAIL", detail);
  fflush(stdout);
  if (ok)
    g_pass++;
  else
    g_fail++;
}

struct opts {
  const char* device;
  int frames;
  int fps;
  int width, height;
};

/* vivid's default test pattern: 8 vertical 75 % bars, white yellow cyan green magenta red blue black */
#define NBARS 8
static const int bar_rgb[NBARS][3] = {{1, 1, 1}, {1, 1, 0}, {0, 1, 1}, {0, 1, 0},
                                      {1, 0, 1}, {1, 0, 0}, {0, 0, 1}, {0, 0, 0}};

/* Mean colour of a 9x9 patch at the centre of bar b, three quarters down (below vivid's OSD text). */
static void bar_colour(const vc_frame* f, int b, int out[3]) {
  int cx = (2 * b + 1) * f->width / (2 * NBARS), cy = f->height * 3 / 4;
  long sum[3] = {0, 0, 0};
  for (int y = cy - 4; y <= cy + 4; y++)
    for (int x = cx - 4; x <= cx + 4; x++)
      for (int c = 0; c < 3; c++) sum[c] += f->rgb[(size_t)y * f->stride + (size_t)x * 3 + (size_t)c];
  for (int c = 0; c < 3; c++) out[c] = (int)(sum[c] / 81);
}

static int bars_rgb_ok(const int bars[NBARS][3], char* why, size_t n) {
  for (int b = 0; b < NBARS; b++)
    for (int c = 0; c < 3; c++) {
      int v = bars[b][c];
      if (bar_rgb[b][c] ? v < 150 : v > 60) {
        snprintf(why, n, "bar%d=(%d,%d,%d)", b, bars[b][0], bars[b][1], bars[b][2]);
        return 0;
      }
    }
  return 1;
}

static int bars_grey_ok(const int bars[NBARS][3], char* why, size_t n) {
  for (int b = 0; b < NBARS; b++) {
    if (bars[b][0] != bars[b][1] || bars[b][1] != bars[b][2]) {
      snprintf(why, n, "bar%d not grey (%d,%d,%d)", b, bars[b][0], bars[b][1], bars[b][2]);
      return 0;
    }
    if (b > 0 && bars[b][0] >= bars[b - 1][0]) {
      snprintf(why, n, "luma not decreasing at bar%d (%d >= %d)", b, bars[b][0], bars[b - 1][0]);
      return 0;
    }
  }
  return 1;
}

static void bars_str(const int bars[NBARS][3], char* out, size_t n) {
  size_t len = 0;
  out[0] = '\0';
  for (int b = 0; b < NBARS && len < n; b++)
    len += (size_t)snprintf(out + len, n - len, "%s%d/%d/%d", b ? "," : "", bars[b][0], bars[b][1], bars[b][2]);
}

static int open_cam(const struct opts* o, vc_pixfmt fmt, int w, int h, const vc_camera_control* ctrls,
                    size_t nctrls, vc_camera** cam, char* why, size_t why_len) {
  vc_camera_config cfg;
  vc_camera_config_init(&cfg);
  cfg.backend = "v4l2";
  cfg.device = o->device;
  cfg.pixfmt = fmt;
  cfg.width = w;
  cfg.height = h;
  cfg.fps_num = (uint32_t)o->fps;
  cfg.fps_den = 1;
  cfg.buffers = 4;
  cfg.controls = ctrls;
  cfg.n_controls = nctrls;
  return vc_camera_open_backend(&vc_camera_backend_v4l2, &cfg, cam, why, why_len);
}

/* Captures o->frames frames in one format; rgb_ref holds (or receives, for RGB24) the bar colours. */
static void run_format(const struct opts* o, vc_pixfmt fmt, int rgb_ref[NBARS][3], int* have_ref) {
  const char* name = vc_pixfmt_name(fmt);
  char check[64], why[512] = "";
  vc_camera* cam = NULL;
  vc_camera_info info;
  vc_camera_stats st;
  /* vivid writes status text over the left bars unless told not to: a control set through the hook */
  const vc_camera_control no_osd[] = {{"OSD Text Mode", 0, 2 /* None */}};
  int rc = open_cam(o, fmt, o->width, o->height, no_osd, 1, &cam, why, sizeof why);
  snprintf(check, sizeof check, "open_%s", name);
  report(check, rc == 0, "rc=%d msg=\"%s\"", rc, why);
  if (rc) return;
  vc_camera_get_info(cam, &info);
  snprintf(check, sizeof check, "rate_%s", name);
  report(check, info.fps_num == (uint32_t)o->fps && info.fps_den == 1, "granted=%u/%u requested=%d/1 driver=%s",
         info.fps_num, info.fps_den, o->fps, info.driver);

  rc = vc_camera_start(cam);
  if (rc) {
    snprintf(check, sizeof check, "stream_%s", name);
    report(check, 0, "start rc=%d msg=\"%s\"", rc, vc_camera_last_error(cam));
    vc_camera_free(cam);
    return;
  }
  uint64_t first_t = 0, last_t = 0, first_seq = 0, last_seq = 0;
  int got = 0, dup_seq = 0, ts_ok = 1, seq_ok = 1, driver_ts = 1, bars_ok = 1, bars_checked = 0;
  int bars[NBARS][3];
  char bar_why[160] = "", seq_why[96] = "";
  for (int i = 0; i < o->frames; i++) {
    vc_frame f;
    rc = vc_camera_capture(cam, 3000, &f);
    if (rc) {
      snprintf(bar_why, sizeof bar_why, "capture %d: %s", i, vc_camera_last_error(cam));
      break;
    }
    if (got == 0) {
      first_t = f.t_ns;
      first_seq = f.sequence;
    } else {
      if (f.t_ns <= last_t) ts_ok = 0;
      /* vivid's jiffies-paced thread can hand out one sequence number twice (rounding of 1/HZ);
       * a driver sequence must never go back */
      if (f.sequence == last_seq) dup_seq++;
      if (f.sequence < last_seq && seq_ok) {
        seq_ok = 0;
        snprintf(seq_why, sizeof seq_why, "seq %llu after %llu at frame %d", (unsigned long long)f.sequence,
                 (unsigned long long)last_seq, i);
      }
    }
    if (!(f.flags & VC_FRAME_TS_DRIVER)) driver_ts = 0;
    last_t = f.t_ns;
    last_seq = f.sequence;
    got++;
    /* check the pattern on a spread of frames; the bars do not move */
    if (bars_ok && (i % 10 == 5 || i == o->frames - 1)) {
      bar_colour(&f, 0, bars[0]);
      for (int b = 1; b < NBARS; b++) bar_colour(&f, b, bars[b]);
      bars_checked++;
      if (fmt == VC_PIXFMT_GREY) {
        bars_ok = bars_grey_ok(bars, bar_why, sizeof bar_why);
      } else {
        bars_ok = bars_rgb_ok(bars, bar_why, sizeof bar_why);
        if (bars_ok && fmt == VC_PIXFMT_RGB24 && !*have_ref) {
          memcpy(rgb_ref, bars, sizeof bars);
          *have_ref = 1;
        } else if (bars_ok && fmt != VC_PIXFMT_RGB24 && *have_ref) {
          for (int b = 0; b < NBARS && bars_ok; b++)
            for (int c = 0; c < 3; c++)
              if (abs(bars[b][c] - rgb_ref[b][c]) > 8) {
                bars_ok = 0;
                snprintf(bar_why, sizeof bar_why, "bar%d ch%d %d vs rgb24 %d", b, c, bars[b][c], rgb_ref[b][c]);
                break;
              }
        }
      }
    }
    vc_camera_release(cam, &f);
  }
  vc_camera_get_stats(cam, &st);
  double span_ms = got > 1 ? (double)(last_t - first_t) / 1e6 : 0.0;
  double period_ms = got > 1 ? span_ms / (double)(last_seq - first_seq) : 0.0;
  char bstr[200];
  bars_str(bars, bstr, sizeof bstr);

  snprintf(check, sizeof check, "stream_%s", name);
  report(check, got == o->frames && ts_ok && seq_ok && driver_ts,
         "size=%dx%d frames=%d ts_increasing=%d seq_monotonic=%d seq_repeats=%d driver_ts=%d dropped=%llu span_ms=%.1f "
         "period_ms=%.2f %s",
         info.width, info.height, got, ts_ok, seq_ok, dup_seq, driver_ts, (unsigned long long)st.dropped, span_ms,
         period_ms, got == o->frames ? seq_why : bar_why);
  snprintf(check, sizeof check, "period_%s", name);
  /* vivid paces frames by jiffies: allow 15 % either way, the emulator's clock is not an oscillator */
  double want_ms = 1000.0 / o->fps;
  report(check, got > 1 && period_ms > want_ms * 0.85 && period_ms < want_ms * 1.15,
         "period_ms=%.3f expected=%.3f", period_ms, want_ms);
  snprintf(check, sizeof check, "pattern_%s", name);
  report(check, got > 0 && bars_checked > 0 && bars_ok, "checked=%d bars=%s %s", bars_checked, bstr,
         bars_ok ? "" : bar_why);
  vc_camera_stop(cam);
  vc_camera_free(cam);
}

/* Presses a button control on its own file handle (fault injection outside the backend). */
static int press_button(const char* dev, const char* key) {
  int fd = open(dev, O_RDWR | O_CLOEXEC);
  if (fd < 0) return -errno;
  struct v4l2_query_ext_ctrl q;
  memset(&q, 0, sizeof q);
  q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
  int rc = -ENOENT;
  while (ioctl(fd, VIDIOC_QUERY_EXT_CTRL, &q) == 0) {
    char k[64];
    vc_v4l2_control_key(q.name, k, sizeof k);
    if (strcmp(k, key) == 0) {
      struct v4l2_control c = {.id = q.id, .value = 1};
      rc = ioctl(fd, VIDIOC_S_CTRL, &c) == 0 ? 0 : -errno;
      break;
    }
    q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
  }
  close(fd);
  return rc;
}

static void run_errors(const struct opts* o) {
  char why[512] = "";
  vc_camera* cam = NULL;
  int rc;

  rc = open_cam(o, VC_PIXFMT_YUYV, 333, 77, NULL, 0, &cam, why, sizeof why);
  report("error_bad_size", rc == -ENOTSUP && strstr(why, "333x77 not supported") != NULL,
         "rc=%d msg=\"%s\"", rc, why);
  vc_camera_free(cam);
  cam = NULL;

  struct opts missing = *o;
  missing.device = "/dev/video-does-not-exist";
  rc = open_cam(&missing, VC_PIXFMT_YUYV, o->width, o->height, NULL, 0, &cam, why, sizeof why);
  report("error_missing_device", rc == -ENOENT && strstr(why, "/dev/video-does-not-exist") != NULL,
         "rc=%d msg=\"%s\"", rc, why);
  vc_camera_free(cam);
  cam = NULL;

  const vc_camera_control unknown[] = {{"no_such_control", 0, 1}};
  rc = open_cam(o, VC_PIXFMT_YUYV, o->width, o->height, unknown, 1, &cam, why, sizeof why);
  report("error_unknown_control", rc == -ENOENT && strstr(why, "no_such_control") != NULL, "rc=%d msg=\"%s\"",
         rc, why);
  vc_camera_free(cam);
  cam = NULL;

  /* a corrupt frame is skipped and counted, the stream goes on */
  const vc_camera_control corrupt[] = {{"Inject V4L2_BUF_FLAG_ERROR", 0, 1}};
  rc = open_cam(o, VC_PIXFMT_YUYV, o->width, o->height, corrupt, 1, &cam, why, sizeof why);
  if (rc == 0) rc = vc_camera_start(cam);
  int got = 0;
  for (int i = 0; rc == 0 && i < 5; i++) {
    vc_frame f;
    rc = vc_camera_capture(cam, 3000, &f);
    if (rc == 0) {
      got++;
      vc_camera_release(cam, &f);
    }
  }
  vc_camera_stats st = {0};
  if (cam) vc_camera_get_stats(cam, &st);
  report("error_corrupt_frame_skipped", rc == 0 && got == 5 && st.corrupted == 1,
         "rc=%d frames=%d corrupted=%llu msg=\"%s\"", rc, got, (unsigned long long)st.corrupted,
         cam ? vc_camera_last_error(cam) : why);
  vc_camera_free(cam);
  cam = NULL;

  /* the driver stops returning buffers: the capture times out with a clear message */
  const vc_camera_control stall[] = {{"percentage_of_dropped_buffers", 0, 100}};
  rc = open_cam(o, VC_PIXFMT_YUYV, o->width, o->height, stall, 1, &cam, why, sizeof why);
  if (rc == 0) rc = vc_camera_start(cam);
  if (rc == 0) {
    vc_frame f;
    rc = vc_camera_capture(cam, 500, &f);
    if (rc == 0) vc_camera_release(cam, &f);
  }
  report("error_stopped_delivering",
         rc == -ETIMEDOUT && cam && strstr(vc_camera_last_error(cam), "camera stopped delivering") != NULL,
         "rc=%d msg=\"%s\"", rc, cam ? vc_camera_last_error(cam) : why);
  if (cam) {
    /* put the driver back the way it was for anything after us */
    vc_camera_free(cam);
    cam = NULL;
    const vc_camera_control unstall[] = {{"percentage_of_dropped_buffers", 0, 0}};
    if (open_cam(o, VC_PIXFMT_YUYV, o->width, o->height, unstall, 1, &cam, why, sizeof why) == 0)
      vc_camera_free(cam);
    cam = NULL;
  }

  /* the device goes away mid-stream (vivid emulates a USB unplug) */
  rc = open_cam(o, VC_PIXFMT_YUYV, o->width, o->height, NULL, 0, &cam, why, sizeof why);
  if (rc == 0) rc = vc_camera_start(cam);
  if (rc == 0) {
    vc_frame f;
    rc = vc_camera_capture(cam, 3000, &f);
    if (rc == 0) vc_camera_release(cam, &f);
  }
  int rc_disc = -1;
  if (rc == 0) {
    /* the fault is injected from a second handle, as a test harness would: not through the backend */
    rc_disc = press_button(o->device, "disconnect");
    if (rc_disc) snprintf(why, sizeof why, "pressing vivid's disconnect control failed: %d", rc_disc);
    for (int i = 0; rc_disc == 0 && i < 10; i++) {
      vc_frame f;
      rc_disc = vc_camera_capture(cam, 1000, &f);
      if (rc_disc) break;
      vc_camera_release(cam, &f);
    }
  }
  report("error_disconnect", rc == 0 && rc_disc == -ENODEV && strstr(vc_camera_last_error(cam), "disconnected"),
         "rc=%d rc_after=%d msg=\"%s\"", rc, rc_disc, cam ? vc_camera_last_error(cam) : why);
  vc_camera_free(cam);
}

int main(int argc, char** argv) {
  struct opts o = {.device = "/dev/video0", .frames = 60, .fps = 60, .width = 320, .height = 180};
  for (int i = 1; i < argc; i++) {
    if (strcmp(argv[i], "--device") == 0 && i + 1 < argc)
      o.device = argv[++i];
    else if (strcmp(argv[i], "--frames") == 0 && i + 1 < argc)
      o.frames = atoi(argv[++i]);
    else if (strcmp(argv[i], "--fps") == 0 && i + 1 < argc)
      o.fps = atoi(argv[++i]);
    else if (strcmp(argv[i], "--size") == 0 && i + 1 < argc) {
      if (sscanf(argv[++i], "%dx%d", &o.width, &o.height) != 2) return 2;
    } else {
      fprintf(stderr, "usage: %s [--device DEV] [--frames N] [--fps F] [--size WxH]\n", argv[0]);
      return 2;
    }
  }
  if (o.frames < 2 || o.fps <= 0 || o.width < 64 || o.height < 16) return 2;
  printf("VCVM-START device=%s frames=%d fps=%d size=%dx%d\n", o.device, o.frames, o.fps, o.width, o.height);
  int rgb_ref[NBARS][3] = {{0}};
  int have_ref = 0;
  /* RGB24 first: it is the reference the converted formats are compared with */
  run_format(&o, VC_PIXFMT_RGB24, rgb_ref, &have_ref);
  run_format(&o, VC_PIXFMT_YUYV, rgb_ref, &have_ref);
  run_format(&o, VC_PIXFMT_GREY, rgb_ref, &have_ref);
  run_errors(&o);
  printf("VCVM-SUMMARY pass=%d fail=%d\n", g_pass, g_fail);
  fflush(stdout);
  return g_fail ? 1 : 0;
}
