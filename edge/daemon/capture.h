/* vc_capture: the edge's two cameras and its trigger input, each on its own thread, delivering
 * complete frame pairs to the pipeline thread.
 *
 * Threads: one capture thread per camera (it alone drives its vc_camera: capture, copy the frame into
 * one of a few slots the capture owns, release the driver buffer at once, hand the slot to the frame
 * queue); one trigger thread (pulses into the frame queue and, for cameras that expose only when
 * triggered, the soft trigger). The pairing and the queues are vc_frameq's (frameq.h), called under
 * the capture's one mutex. Copying frames costs ~0.1 ms per frame pair at 640x480 and buys a driver
 * buffer that is always free and slots no other thread can release under us.
 *
 * Phases: IDLE (frames and pulses are dropped), BACKGROUND (the host asks for the empty scene),
 * RUNNING. The capture never asks which backend a camera is; it asks what it can do (vc_camera_caps):
 * a camera that exposes only when triggered in software gets each pulse from the trigger thread; a
 * camera that plays a sequence is rewound when the phase changes — to the empty scene while the host
 * learns the background, to seq_base = START's first seq while running, so that every node shows the
 * same motion frame for the same pulse. Cameras of the real room are opened once and left alone.
 */
#ifndef VOXCAP_EDGE_CAPTURE_H
#define VOXCAP_EDGE_CAPTURE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "frameq.h"
#include "voxcap/edge/camera.h"
#include "voxcap/edge/trigger.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_capture vc_capture;

typedef enum vc_capture_phase {
  VC_CAPTURE_IDLE = 0,
  VC_CAPTURE_BACKGROUND,
  VC_CAPTURE_RUNNING
} vc_capture_phase;

typedef struct vc_capture_options {
  vc_camera_config cameras[VC_FRAMEQ_CAMS]; /* strings borrowed for the capture's lifetime */
  const vc_trigger_config* trigger;         /* borrowed during vc_capture_new only */
  vc_pairing_config pairing;                /* ncams, pulse_slots and frame_slots are set by the capture */
  unsigned frame_slots;                     /* copied frames per camera, 0 = 4, at most VC_FRAMEQ_MAX_SLOTS */
  int camera_timeout_ms; /* a camera that delivers nothing this long is reported, 0 = 2000 */
} vc_capture_options;

typedef struct vc_capture_callbacks {
  /* A camera or the trigger failed at run time (code: VC_ERR_CAMERA or VC_ERR_TRIGGER): the daemon
   * logs it and tells the host. Called from the capture threads. */
  void (*error)(void* user, uint32_t code, const char* text);
  void* user;
} vc_capture_callbacks;

/* A complete pair handed to the pipeline: the pixels stay valid until vc_capture_done(). */
typedef struct vc_capture_pair {
  vc_frame_pair pair;
  const uint8_t* rgb[VC_FRAMEQ_CAMS];
  size_t stride[VC_FRAMEQ_CAMS];
} vc_capture_pair;

typedef struct vc_capture_stats {
  uint64_t frames[VC_FRAMEQ_CAMS];        /* frames captured */
  uint64_t errors[VC_FRAMEQ_CAMS];        /* camera errors (capture failures, silences reported) */
  uint64_t missed_pulses[VC_FRAMEQ_CAMS]; /* triggered-only cameras: pulses that came while busy */
  vc_frameq_stats queue;
} vc_capture_stats;

/* Opens the trigger input and both cameras, allocates the slots; no thread runs yet (phase IDLE).
 * *out owns the capture. On failure returns a negative code, *out = NULL and a one-line reason in why
 * (if given). */
int vc_capture_new(const vc_capture_options* opt, const vc_capture_callbacks* cb, vc_capture** out, char* why,
                   size_t why_len);
/* Stops the threads, closes cameras and trigger. NULL is a no-op. */
void vc_capture_free(vc_capture* cap);

void vc_capture_get_camera_info(const vc_capture* cap, int cam, vc_camera_info* info);
void vc_capture_get_trigger_info(const vc_capture* cap, vc_trigger_info* info);

/* Starts the camera and trigger threads. */
int vc_capture_start(vc_capture* cap);

/* Enters a phase (pipeline thread only): drops every frame, pulse and pair of the previous one;
 * seq_base is the first pulse of the phase (BACKGROUND: the next pulse; RUNNING: START's seq). */
int vc_capture_set_phase(vc_capture* cap, vc_capture_phase ph, uint64_t seq_base);
vc_capture_phase vc_capture_get_phase(vc_capture* cap);
/* The seq of the last pulse the trigger input delivered (0 before the first). */
uint64_t vc_capture_last_pulse_seq(vc_capture* cap);

/* Waits up to timeout_ms for a complete pair (or vc_capture_wake). true with *out filled when there
 * is one; the caller gives it back with vc_capture_done. */
bool vc_capture_next(vc_capture* cap, int timeout_ms, vc_capture_pair* out);
void vc_capture_done(vc_capture* cap, const vc_capture_pair* pair);
/* Makes a waiting (or the next) vc_capture_next return at once. Any thread. */
void vc_capture_wake(vc_capture* cap);

/* The capture stage (pulse → both frames in memory, RUNNING only) since the last call; resets it. */
void vc_capture_take_capture_time(vc_capture* cap, uint64_t* sum_ns, uint64_t* max_ns, uint64_t* n);
void vc_capture_get_stats(vc_capture* cap, vc_capture_stats* out);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_CAPTURE_H */
