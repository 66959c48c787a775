/* vc_camera: one interface over the edge's camera backends.
 *
 * Backends, chosen by name from the configuration (never by #ifdef):
 *   "v4l2"      a V4L2 capture node, mmap streaming, YUYV/UYVY/RGB24/BGR24/GREY converted in fixed point
 *   "libcamera" a libcamera 0.3 camera (Raspberry Pi OS's stack), by id or index
 *   "file"      the image folders `voxcap sim` writes (DIR/cam<k>/<frame>.png)
 *   "sim"       the virtual rig (hw/sim) rendered in-process
 * Every backend delivers interleaved RGB24 frames stamped in CLOCK_MONOTONIC ns (see clock.h) with the
 * driver's frame sequence number. A node runs two cameras: two vc_camera objects, one thread each.
 *
 * Lifecycle: vc_camera_open → vc_camera_start → (vc_camera_capture → vc_camera_release)* →
 * vc_camera_stop [→ vc_camera_rewind] [→ vc_camera_start ...] → vc_camera_free.
 *
 * Capabilities (vc_camera_caps) say what a camera does beyond capturing, so that its user never asks
 * which backend it is: VC_CAMERA_CAP_SOFT_TRIGGER — it exposes a frame only when told through
 * vc_camera_soft_trigger (the emulated twin of a sensor on a trigger wire; file and sim in triggered
 * mode); VC_CAMERA_CAP_REWIND — it plays a recorded or rendered sequence that vc_camera_rewind restarts
 * at a given pulse, showing the empty scene or the performer (file, sim). Real cameras have neither:
 * their trigger is a wire and what they see is the room. (libcamera's virtual pipeline and V4L2's vivid
 * do likewise: the test source is an ordinary camera with extra controls, not a special case.)
 *
 * Errors: every function returns 0 (or a count) or a negative errno-style code and, on failure, leaves
 * a one-line message naming the backend and device in vc_camera_last_error() — what the edge daemon
 * forwards to the host as ERROR. Codes a caller may act on:
 *   -ENOENT     device / folder / camera id missing        -ENODEV   device disappeared
 *   -ENOTSUP    format, size or feature not supported     -EBUSY    device in use; all frames held
 *   -ETIMEDOUT  the camera stopped delivering             -ENODATA  file backend: end of the sequence
 *   -EINVAL     bad configuration                         -EIO      driver or decoding error
 * A vc_camera is not thread-safe: one thread drives it (vc_camera_soft_trigger excepted).
 */
#ifndef VOXCAP_EDGE_CAMERA_H
#define VOXCAP_EDGE_CAMERA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_camera vc_camera;

/* Pixel formats a device may deliver before conversion to RGB24. */
typedef enum vc_pixfmt {
  VC_PIXFMT_DEFAULT = 0, /* backend's choice (v4l2: YUYV) */
  VC_PIXFMT_RGB24,       /* R,G,B bytes */
  VC_PIXFMT_BGR24,       /* B,G,R bytes */
  VC_PIXFMT_YUYV,        /* Y0 U Y1 V, 4:2:2 */
  VC_PIXFMT_UYVY,        /* U Y0 V Y1, 4:2:2 */
  VC_PIXFMT_GREY,        /* 8-bit luma */
} vc_pixfmt;

/* "rgb24", "bgr24", "yuyv", "uyvy", "grey" ("default" for VC_PIXFMT_DEFAULT); NULL if unknown. */
const char* vc_pixfmt_name(vc_pixfmt fmt);
/* Parses the names above (case-insensitive; "gray" accepted). 0 or -EINVAL. */
int vc_pixfmt_from_name(const char* name, vc_pixfmt* out);

/* A device control applied at open (v4l2: by V4L2 control id, or by name as v4l2-ctl spells it, e.g.
 * "exposure_time_absolute" or a sensor's "trigger_mode"; buttons take any value). This is the hook for
 * a sensor's external-trigger mode: the driver decides what it means; nothing is faked. */
typedef struct vc_camera_control {
  const char* name; /* NULL to use id */
  uint32_t id;
  int64_t value;
} vc_camera_control;

typedef struct vc_camera_config {
  const char* backend;        /* "v4l2" | "libcamera" | "file" | "sim" (required) */
  const char* device;         /* v4l2: device node ("/dev/video0"); libcamera: camera id or index ("0");
                                 file: folder written by `voxcap sim`; sim: scene spec (see camera_sim) */
  int index;                  /* the camera's number in the rig: file/sim read/render cam<index> */
  int width, height;          /* requested size (0 = backend default); the backend may adjust: see info */
  vc_pixfmt pixfmt;           /* v4l2 capture format; other backends ignore it */
  uint32_t fps_num;           /* frame rate fps_num/fps_den Hz (0 = driver default) */
  uint32_t fps_den;           /* 0 means 1 */
  unsigned buffers;           /* driver buffers / libcamera requests (0 = 4) */
  unsigned held_frames;       /* frames the caller may hold unreleased at once (0 = 2) */
  bool external_trigger;      /* the sensor is externally triggered (libcamera: fixed frame duration
                                 and exposure; file/sim: a frame per vc_camera_soft_trigger) */
  int64_t exposure_us;        /* fixed exposure (libcamera: AeEnable=false + ExposureTime); 0 = auto */
  int64_t trigger_latency_ns; /* the sensor's frame time minus its trigger edge (what the pairer
                                 expects); backends that synthesise stamps (file, sim) use it */
  const vc_camera_control* controls; /* borrowed during vc_camera_open only */
  size_t n_controls;
  const char* options; /* backend-specific "key=value,..." parsed by that backend, NULL = none;
                          file, sim: pace=0|1, loop=0|1 (file), scene=live|empty, seq_base=N */
} vc_camera_config;

/* Fills *cfg with the defaults documented above (all zero/NULL except fps_den = 1). */
void vc_camera_config_init(vc_camera_config* cfg);

/* Frame flags */
#define VC_FRAME_TS_DRIVER 0x1u  /* t_ns is the driver's/sensor's capture time */
#define VC_FRAME_TS_DEQUEUE 0x2u /* the driver gave none usable: t_ns is the dequeue time */
#define VC_FRAME_TS_SYNTH 0x4u   /* emulated backend: t_ns synthesised from fps or the pulse */

typedef struct vc_frame {
  uint8_t* rgb; /* interleaved R,G,B; owned by the camera, valid until vc_camera_release() */
  int width, height;
  size_t stride;     /* bytes per row (>= 3 * width) */
  uint64_t t_ns;     /* capture time, CLOCK_MONOTONIC ns */
  uint64_t sequence; /* driver frame counter, widened to 64 bits (gaps = frames the driver dropped) */
  uint64_t index;    /* emulated backends: the image index shown; others: = sequence */
  uint32_t flags;    /* VC_FRAME_TS_* */
  int slot;          /* private: which held buffer */
} vc_frame;

typedef struct vc_camera_info {
  const char* backend; /* static string */
  char device[128];
  char driver[64];           /* v4l2: driver/card; libcamera: camera id; file: folder */
  int width, height;         /* actual size after negotiation */
  vc_pixfmt pixfmt;          /* format actually captured */
  uint32_t fps_num, fps_den; /* actual frame rate (0/1 if unknown) */
  unsigned buffers;          /* actual driver buffers */
} vc_camera_info;

typedef struct vc_camera_stats {
  uint64_t frames;    /* frames delivered */
  uint64_t dropped;   /* gaps in the driver sequence */
  uint64_t corrupted; /* frames the driver marked bad (skipped) */
  uint64_t timeouts;  /* captures that hit their timeout */
} vc_camera_stats;

/* Opens the camera: validates cfg, picks the backend by cfg->backend, opens and configures the
 * device (format, size, rate, controls). On success *out owns a camera (free with vc_camera_free).
 * On failure returns a negative code, *out = NULL and, if why != NULL, a one-line message in why. */
int vc_camera_open(const vc_camera_config* cfg, vc_camera** out, char* why, size_t why_len);

/* Starts streaming. */
int vc_camera_start(vc_camera* cam);
/* Waits up to timeout_ms (< 0: forever) for the next frame. On success *frame refers to a buffer the
 * caller holds until vc_camera_release(). -ETIMEDOUT: "camera stopped delivering". */
int vc_camera_capture(vc_camera* cam, int timeout_ms, vc_frame* frame);
/* Returns a held frame's buffer; frame->rgb is invalid afterwards. */
int vc_camera_release(vc_camera* cam, vc_frame* frame);
/* Emulated external trigger (file, sim with external_trigger): the pulse `seq` fired at t_ns; the
 * next capture returns its frame. -ENOTSUP for real cameras, whose trigger is a wire. The one call
 * that may come from another thread than the capturing one (the trigger input's). */
int vc_camera_soft_trigger(vc_camera* cam, uint64_t seq, uint64_t t_ns);
/* What the camera can do beyond capturing: VC_CAMERA_CAP_* (see the top of this file). */
#define VC_CAMERA_CAP_SOFT_TRIGGER 0x1u /* exposes a frame only per vc_camera_soft_trigger */
#define VC_CAMERA_CAP_REWIND 0x2u       /* vc_camera_rewind restarts its sequence */
uint32_t vc_camera_caps(const vc_camera* cam);

/* What a rewound camera shows: the performer, or the empty scene the host's BACKGROUND asks for. */
typedef enum vc_camera_scene { VC_CAMERA_SCENE_LIVE = 0, VC_CAMERA_SCENE_EMPTY = 1 } vc_camera_scene;
/* VC_CAMERA_CAP_REWIND: restarts the sequence so that the frame shown for pulse seq is frame
 * seq − seq_base of `scene` (free-running: from frame 0); the empty scene loops. Triggers not yet
 * captured are dropped. Call it while the camera is stopped. -ENOTSUP without the capability, -EBUSY
 * while streaming, -ENOENT when the backend has no such scene (file: no background folder). */
int vc_camera_rewind(vc_camera* cam, uint64_t seq_base, vc_camera_scene scene);
/* Stops streaming; held frames stay valid until released or the camera is freed. */
int vc_camera_stop(vc_camera* cam);
/* Stops if needed and frees everything. NULL is a no-op. */
void vc_camera_free(vc_camera* cam);

/* Last error message ("" if none); valid until the next call on cam. */
const char* vc_camera_last_error(const vc_camera* cam);
/* Last error code (0 if none). */
int vc_camera_last_errno(const vc_camera* cam);
void vc_camera_get_info(const vc_camera* cam, vc_camera_info* info);
void vc_camera_get_stats(const vc_camera* cam, vc_camera_stats* stats);

/* Names of the compiled-in backends, NULL-terminated (static). */
const char* const* vc_camera_backend_names(void);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_CAMERA_H */
