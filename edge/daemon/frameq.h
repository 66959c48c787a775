/* vc_frameq: the edge daemon's frame pairs as pure logic — no threads, no clock, no devices — so that
 * it is tested frame by frame (tests/frameq_test.cpp).
 *
 * The capture side owns a few frame slots per camera (the pixels); the frame queue owns their states:
 *
 *   FREE --acquire--> FILLED --pairer: MATCHED--> MATCHED --pairer: COMPLETE--> WORK --done--> FREE
 *     ^                 |                           |                             |
 *     '------ pairer: FRAME_UNMATCHED / PULSE_UNMATCHED, reset, a dropped pair ---'
 *
 * Frames (by slot) and trigger pulses go into the pairer (edge/trigger/pairing.h), which matches them
 * by timestamp; a pulse with a frame from both cameras becomes a vc_frame_pair in the work queue. The
 * work queue is bounded (VC_FRAMEQ_WORK): when the pipeline is behind, the oldest pair is dropped and
 * counted, so capture never waits for it. A slot the pipeline holds (WORK) is never handed out again
 * until vc_frameq_done().
 *
 * Times are passed in (now_ns: CLOCK_MONOTONIC ns); the queue keeps the capture stage's figures (pulse
 * → both frames paired) while timing is on. Not thread-safe: the daemon calls it under one mutex.
 */
#ifndef VOXCAP_EDGE_FRAMEQ_H
#define VOXCAP_EDGE_FRAMEQ_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/edge/pairing.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VC_FRAMEQ_CAMS 2
#define VC_FRAMEQ_MAX_SLOTS 8 /* frame slots per camera */
#define VC_FRAMEQ_WORK 8      /* complete pairs waiting for the pipeline */
#define VC_FRAMEQ_PEND 32     /* pulses with some but not all frames matched (> pairer's pulse_slots) */

typedef struct vc_frameq vc_frameq;

/* A pulse with a frame from each camera. */
typedef struct vc_frame_pair {
  uint64_t seq;             /* the pulse's seq */
  uint64_t t_ns;            /* the pulse's time (trigger edge), CLOCK_MONOTONIC */
  uint64_t paired_ns;       /* when the pair became complete (the now_ns of that call) */
  int slot[VC_FRAMEQ_CAMS]; /* each camera's slot */
} vc_frame_pair;

typedef struct vc_frameq_stats {
  uint64_t work_drops;                 /* complete pairs dropped because the pipeline was behind */
  uint64_t slot_drops[VC_FRAMEQ_CAMS]; /* frames dropped because every slot of the camera was taken */
  vc_pairing_stats pairing;
} vc_frameq_stats;

/* A queue over nslots (1..VC_FRAMEQ_MAX_SLOTS) slots per camera. pairing->ncams must be 2 and
 * pairing->frame_slots at least nslots; pulse_slots below VC_FRAMEQ_PEND. The queue starts closed
 * (see vc_frameq_reset). 0, -EINVAL (why says what) or -ENOMEM; *out owns the queue. */
int vc_frameq_new(const vc_pairing_config* pairing, unsigned nslots, vc_frameq** out, char* why,
                  size_t why_len);
void vc_frameq_free(vc_frameq* q); /* NULL is a no-op */

/* Forgets every frame, pulse and pair of the previous phase (all slots FREE) and opens the queue
 * (`open`: frames and pulses are taken) or closes it (neither is). Pulses with seq < min_seq are
 * ignored. With time_capture the capture stage (pulse → pair complete) is accumulated. */
void vc_frameq_reset(vc_frameq* q, bool open, uint64_t min_seq, bool time_capture);
bool vc_frameq_is_open(const vc_frameq* q);

/* A free slot of camera cam for the next frame: its index, -EAGAIN when the queue is closed, or
 * -EBUSY when every slot is taken (counted in slot_drops: the pipeline is behind). */
int vc_frameq_acquire(vc_frameq* q, unsigned cam);
/* Slot `slot` of camera cam (from vc_frameq_acquire) now holds a frame stamped t_ns. */
void vc_frameq_add_frame(vc_frameq* q, unsigned cam, int slot, uint64_t t_ns, uint64_t now_ns);
/* A trigger pulse. Returns true when it was taken (queue open, seq >= min_seq). */
bool vc_frameq_add_pulse(vc_frameq* q, uint64_t seq, uint64_t t_ns, uint64_t now_ns);
/* Resolves frames and pulses that waited longer than the pairer's max delay. */
void vc_frameq_advance(vc_frameq* q, uint64_t now_ns);

/* The oldest complete pair, if any (its slots stay WORK until vc_frameq_done). */
bool vc_frameq_pop(vc_frameq* q, vc_frame_pair* out);
unsigned vc_frameq_ready(const vc_frameq* q); /* complete pairs waiting */
/* The pipeline is done with a popped pair: its slots are freed unless a reset already did. */
void vc_frameq_done(vc_frameq* q, const vc_frame_pair* pair);

/* The capture stage since the last call (sum and max of pulse → pair complete, over n pairs), then
 * resets it. */
void vc_frameq_take_capture_time(vc_frameq* q, uint64_t* sum_ns, uint64_t* max_ns, uint64_t* n);
void vc_frameq_get_stats(const vc_frameq* q, vc_frameq_stats* out);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_FRAMEQ_H */
