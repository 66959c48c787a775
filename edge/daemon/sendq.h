/* vc_sendq: the edge's bounded outgoing message queue.
 *
 * The capture pipeline must never block on the network, and a slow or absent link must never grow
 * memory. The queue holds at most `max_msgs` messages and `max_bytes` bytes; pushing into a full
 * queue drops the OLDEST messages (counted) — for a live rig the newest frame is the one worth
 * sending. Message buffers are recycled: after warm-up, push and pop allocate nothing unless a
 * message is larger than any seen before.
 *
 * Thread-safe: one or more producers push, one consumer (the link thread) peeks/pops.
 */
#ifndef VOXCAP_EDGE_SENDQ_H
#define VOXCAP_EDGE_SENDQ_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_sendq vc_sendq;

typedef struct vc_sendq_stats {
  uint64_t pushed;  /* messages accepted */
  uint64_t dropped; /* messages dropped to make room (drop-oldest) */
  uint64_t dropped_bytes;
  uint64_t sent;   /* messages popped after being written */
  uint32_t queued; /* messages now in the queue */
  size_t queued_bytes;
} vc_sendq_stats;

/* A queue of at most max_msgs (1..4096) messages and max_bytes bytes; *out owns it (vc_sendq_free).
 * 0, -EINVAL or -ENOMEM with *out = NULL and a one-line reason in why (if given). */
int vc_sendq_new(unsigned max_msgs, size_t max_bytes, vc_sendq** out, char* why, size_t why_len);
void vc_sendq_free(vc_sendq* q); /* NULL is a no-op */

/* Copies msg[0..len) in. Drops the oldest messages while the queue would exceed its limits (never
 * the one being written by the consumer, see peek). Returns 0, -EMSGSIZE if len alone exceeds
 * max_bytes (the message is dropped and counted), -ENOMEM. */
int vc_sendq_push(vc_sendq* q, const uint8_t* msg, size_t len);

/* Copies msg in only when the queue is then at most half full (messages and bytes), and never drops
 * anything: for messages that must not cost a frame's HULL its place (SILHOUETTE). 0, -ENOBUFS when
 * there is no such room (nothing counted: the caller counts what it did not send), -ENOMEM. */
int vc_sendq_push_if_room(vc_sendq* q, const uint8_t* msg, size_t len);

/* The oldest message, without removing it: *data and *len stay valid until vc_sendq_pop or
 * vc_sendq_clear (push never drops a peeked message). Returns 1, or 0 if the queue is empty. */
int vc_sendq_peek(vc_sendq* q, const uint8_t** data, size_t* len);
/* Removes the peeked (oldest) message after it was sent. */
void vc_sendq_pop(vc_sendq* q);
/* Drops everything (e.g. the connection was lost: stale frames are worthless); counted as dropped. */
void vc_sendq_clear(vc_sendq* q);
/* Waits until the queue is non-empty or timeout_ms passes (< 0: forever). 1 if non-empty, else 0. */
int vc_sendq_wait(vc_sendq* q, int timeout_ms);
/* Wakes a consumer blocked in vc_sendq_wait (e.g. at shutdown). */
void vc_sendq_wake(vc_sendq* q);
void vc_sendq_get_stats(vc_sendq* q, vc_sendq_stats* stats);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_SENDQ_H */
