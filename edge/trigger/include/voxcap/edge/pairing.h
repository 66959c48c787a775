/* vc_pairer: pairs each camera frame with the trigger pulse that exposed it, by timestamp.
 *
 * Pure logic, no I/O, no clock reads: every time is CLOCK_MONOTONIC ns, converted before it gets here
 * (clock.h is the one place that converts). A frame of camera c stamped t_f belongs to the pending
 * pulse p with |t_f − latency[c] − t_p| ≤ tolerance (the nearest if several; with tolerance below half
 * the trigger period there is at most one). latency[c] is the camera's fixed offset between the
 * trigger edge and its timestamp (exposure start vs. readout end, sensor delay).
 *
 * Either side may arrive first (a udp pulse can come after its frame; a gpio edge usually before), so
 * both wait in small fixed rings:
 *   - a pulse is resolved when every camera either delivered its frame (COMPLETE) or is known to
 *     have skipped it: that camera delivered a LATER frame (one camera's frames arrive in time order)
 *     or `now` passed t_p + latency + tolerance + max_delay (PULSE_UNMATCHED, missing cameras named);
 *   - a frame nobody claims is given up once `now` passed t_f − latency + tolerance + max_delay
 *     (FRAME_UNMATCHED). max_delay is how late the other side may arrive.
 * Results come out through a callback, in decision order. Ring overflow (a side stopped entirely for
 * longer than the rings hold) resolves the oldest entry early and is counted. Memory is allocated
 * once, in vc_pairer_new.
 */
#ifndef VOXCAP_EDGE_PAIRING_H
#define VOXCAP_EDGE_PAIRING_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VC_PAIR_MAX_CAMS 4
#define VC_PAIR_MAX_SLOTS 256

typedef struct vc_pairing_config {
  unsigned ncams;                       /* cameras fed to this pairer, 1..VC_PAIR_MAX_CAMS */
  uint64_t tolerance_ns;                /* > 0; keep it under half the trigger period */
  int64_t latency_ns[VC_PAIR_MAX_CAMS]; /* expected frame t − pulse t, per camera */
  uint64_t max_delay_ns;                /* how late either side may arrive after the other */
  unsigned pulse_slots;                 /* pending pulses (0 = 16) */
  unsigned frame_slots;                 /* pending frames per camera (0 = 4) */
} vc_pairing_config;

/* Fills defaults: ncams 2, tolerance 4 ms (half of a 120 fps period), latency 0, max_delay 50 ms. */
void vc_pairing_config_init(vc_pairing_config* cfg);
/* 0, or -EINVAL with a one-line reason in why (if given). */
int vc_pairing_config_check(const vc_pairing_config* cfg, char* why, size_t why_len);

typedef enum vc_pair_event_type {
  VC_PAIR_MATCHED = 0,         /* frame (cam, cookie) belongs to pulse seq */
  VC_PAIR_COMPLETE = 1,        /* every camera has its frame for pulse seq */
  VC_PAIR_PULSE_UNMATCHED = 2, /* pulse seq resolved without frames from missing_mask's cameras */
  VC_PAIR_FRAME_UNMATCHED = 3, /* frame (cam, cookie) matched no pulse */
} vc_pair_event_type;

typedef struct vc_pair_event {
  vc_pair_event_type type;
  unsigned cam;          /* MATCHED, FRAME_UNMATCHED */
  uint64_t seq;          /* MATCHED, COMPLETE, PULSE_UNMATCHED */
  uint64_t pulse_t_ns;   /* MATCHED, COMPLETE, PULSE_UNMATCHED */
  uint64_t frame_t_ns;   /* MATCHED, FRAME_UNMATCHED */
  uint64_t cookie;       /* the caller's frame handle: MATCHED, FRAME_UNMATCHED */
  uint32_t missing_mask; /* PULSE_UNMATCHED: bit c = camera c gave no frame */
  int64_t error_ns;      /* MATCHED: t_f − latency − t_p */
} vc_pair_event;

/* Called synchronously from add_pulse/add_frame/advance/flush; must not call back into the pairer. */
typedef void (*vc_pair_cb)(void* user, const vc_pair_event* ev);

typedef struct vc_pairing_stats {
  uint64_t pulses;                                 /* pulses added (duplicates excluded) */
  uint64_t complete;                               /* pulses with a frame from every camera */
  uint64_t incomplete;                             /* pulses resolved with a camera missing */
  uint64_t matched[VC_PAIR_MAX_CAMS];              /* frames paired */
  uint64_t frames_without_pulse[VC_PAIR_MAX_CAMS]; /* frames that matched no pulse */
  uint64_t pulses_without_frame[VC_PAIR_MAX_CAMS]; /* pulses this camera gave no frame for */
  uint64_t duplicate_pulses;                       /* same seq added twice (ignored) */
  uint64_t overflow;                               /* entries resolved early because a ring was full */
  int64_t error_min_ns[VC_PAIR_MAX_CAMS];          /* over matched frames (0 if none) */
  int64_t error_max_ns[VC_PAIR_MAX_CAMS];
  int64_t error_sum_ns[VC_PAIR_MAX_CAMS]; /* mean = sum / matched */
} vc_pairing_stats;

typedef struct vc_pairer vc_pairer;

/* Allocates a pairer; *out owns it (free with vc_pairer_free). cb is required. 0, -EINVAL or
 * -ENOMEM with *out = NULL and a one-line reason in why (if given). */
int vc_pairer_new(const vc_pairing_config* cfg, vc_pair_cb cb, void* user, vc_pairer** out, char* why,
                  size_t why_len);
void vc_pairer_free(vc_pairer* p); /* NULL is a no-op */

/* A trigger pulse. Returns 0, or -EEXIST if seq is already pending (ignored, counted). */
int vc_pairer_add_pulse(vc_pairer* p, uint64_t seq, uint64_t t_ns);
/* A frame of camera cam (< ncams); cookie comes back in the event. 0 or -EINVAL. */
int vc_pairer_add_frame(vc_pairer* p, unsigned cam, uint64_t t_ns, uint64_t cookie);
/* Resolves everything that can no longer match at time now_ns. */
void vc_pairer_advance(vc_pairer* p, uint64_t now_ns);
/* Resolves everything pending (at stop). */
void vc_pairer_flush(vc_pairer* p);
void vc_pairer_get_stats(const vc_pairer* p, vc_pairing_stats* stats);
/* Pending entries (for tests and diagnostics). */
unsigned vc_pairer_pending_pulses(const vc_pairer* p);
unsigned vc_pairer_pending_frames(const vc_pairer* p, unsigned cam);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_PAIRING_H */
