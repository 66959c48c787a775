/* The edge daemon: capture (capture.h) + node (node.h) + link (link.h), wired together.
 *
 * Threads: the capture's (one per camera, one for the trigger input: capture.h), the link thread
 * (link.h), and the pipeline thread — the caller of vc_edged_run — which applies the host's commands
 * (each changes the capture's phase) and processes every complete frame pair (background learning, or
 * subtract → carve → HULL). Frame pairing and the queues are pure logic in frameq.h.
 */
#ifndef VOXCAP_EDGE_EDGED_H
#define VOXCAP_EDGE_EDGED_H

#include <stdbool.h>
#include <stdint.h>

#include "link.h"
#include "node.h"
#include "voxcap/edge/camera.h"
#include "voxcap/edge/trigger.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_edged_options {
  uint16_t node_id;
  vc_camera_config cameras[2];  /* strings borrowed for the daemon's lifetime */
  int64_t camera_latency_ns[2]; /* frame timestamp − pulse time, per camera */
  vc_trigger_config trigger;
  uint64_t pair_tolerance_ns; /* 0 = 4 ms */
  uint64_t pair_max_delay_ns; /* 0 = 50 ms */
  vc_link_config link;
  int stats_ms;          /* STATS period, 0 = 1000 */
  int camera_timeout_ms; /* a camera that delivers nothing this long is reported, 0 = 2000 */
  unsigned frame_slots;  /* copied frames per camera, 0 = 4 */
  int verbosity;         /* 0 warnings, 1 info, 2 debug */
  const char* state_dir; /* keep the learnt background here and restore it at start (NULL: off) */
  /* The feature tracker (edge/track), installed in the node and announced in HELLO (VC_CAP_FEATURES);
   * it runs when the host's CONFIG gives the node the tracking role. NULL: the node does not track. */
  const vc_features_producer* features;
} vc_edged_options;

/* Opens cameras and trigger once to check the configuration and the devices; prints what it found
 * (or why not) on stdout/stderr. Returns 0 when everything opened. */
int vc_edged_check(const vc_edged_options* opt);

/* Runs until vc_edged_request_stop() (e.g. from a SIGINT/SIGTERM handler). 0 on a clean stop,
 * a negative code when a device could not be opened at all. */
int vc_edged_run(const vc_edged_options* opt);
void vc_edged_request_stop(void); /* async-signal-safe */

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_EDGED_H */
