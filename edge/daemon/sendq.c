/* Bounded drop-oldest message queue: a ring of slots whose buffers are kept and reused. */
#define _POSIX_C_SOURCE 200809L
#include "sendq.h"

#include <errno.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "voxcap/edge/clock.h"
#include "voxcap/why.h"

typedef struct slot {
  uint8_t* buf;
  size_t cap;
  size_t len;
} slot;

struct vc_sendq {
  pthread_mutex_t mu;
  pthread_cond_t cv;
  slot* slots;
  unsigned max_msgs;
  size_t max_bytes;
  unsigned head; /* oldest */
  unsigned count;
  size_t bytes;
  bool peeked; /* the head is being written by the consumer: never drop it */
  bool woken;
  vc_sendq_stats st;
};

int vc_sendq_new(unsigned max_msgs, size_t max_bytes, vc_sendq** out, char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if (!out || max_msgs == 0 || max_msgs > 4096 || max_bytes == 0) {
    vc_why(why, why_len, "send queue: %s",
           !out             ? "invalid arguments"
           : max_bytes == 0 ? "max_bytes must be > 0"
                            : "max_msgs must be 1..4096");
    return -EINVAL;
  }
  vc_sendq* q = calloc(1, sizeof(*q));
  if (!q) goto err_nomem;
  q->slots = calloc(max_msgs, sizeof(slot));
  if (!q->slots) goto err_q;
  q->max_msgs = max_msgs;
  q->max_bytes = max_bytes;
  pthread_mutex_init(&q->mu, NULL);
  pthread_condattr_t ca;
  pthread_condattr_init(&ca);
  pthread_condattr_setclock(&ca, CLOCK_MONOTONIC); /* vc_sendq_wait's deadlines are MONOTONIC */
  pthread_cond_init(&q->cv, &ca);
  pthread_condattr_destroy(&ca);
  *out = q;
  return 0;
err_q:
  free(q);
err_nomem:
  vc_why(why, why_len, "send queue: out of memory");
  return -ENOMEM;
}

void vc_sendq_free(vc_sendq* q) {
  if (!q) return;
  for (unsigned i = 0; i < q->max_msgs; i++) free(q->slots[i].buf);
  free(q->slots);
  pthread_mutex_destroy(&q->mu);
  pthread_cond_destroy(&q->cv);
  free(q);
}

/* Drops the oldest message that is not being sent. Caller holds the lock. Returns false if none. */
static bool drop_oldest(vc_sendq* q) {
  unsigned skip = q->peeked ? 1u : 0u;
  if (q->count <= skip) return false;
  unsigned victim = (q->head + skip) % q->max_msgs;
  size_t len = q->slots[victim].len;
  /* Close the gap: move the peeked head (if any) one slot forward over the victim. */
  if (skip) {
    slot tmp = q->slots[victim];
    q->slots[victim] = q->slots[q->head];
    q->slots[q->head] = tmp;
  }
  q->head = (q->head + 1) % q->max_msgs;
  q->count--;
  q->bytes -= len;
  q->st.dropped++;
  q->st.dropped_bytes += len;
  return true;
}

/* Copies msg into the next free slot and wakes the consumer. Caller holds the lock and made room. */
static int append(vc_sendq* q, const uint8_t* msg, size_t len) {
  slot* s = &q->slots[(q->head + q->count) % q->max_msgs];
  if (s->cap < len) {
    uint8_t* nb = realloc(s->buf, len);
    if (!nb) return -ENOMEM;
    s->buf = nb;
    s->cap = len;
  }
  memcpy(s->buf, msg, len);
  s->len = len;
  q->count++;
  q->bytes += len;
  q->st.pushed++;
  pthread_cond_signal(&q->cv);
  return 0;
}

int vc_sendq_push_if_room(vc_sendq* q, const uint8_t* msg, size_t len) {
  pthread_mutex_lock(&q->mu);
  /* At most half full afterwards, in messages and in bytes: what the queue holds for frames to come. */
  int rc = 2 * (q->count + 1) <= q->max_msgs && 2 * (q->bytes + len) <= q->max_bytes ? append(q, msg, len)
                                                                                     : -ENOBUFS;
  pthread_mutex_unlock(&q->mu);
  return rc;
}

int vc_sendq_push(vc_sendq* q, const uint8_t* msg, size_t len) {
  int rc = 0;
  pthread_mutex_lock(&q->mu);
  if (len > q->max_bytes) {
    q->st.dropped++;
    q->st.dropped_bytes += len;
    rc = -EMSGSIZE;
    goto out;
  }
  while (q->count == q->max_msgs || q->bytes + len > q->max_bytes) {
    if (!drop_oldest(q)) break; /* only the peeked message is left: it may exceed briefly */
  }
  if (q->count == q->max_msgs) { /* max_msgs == 1 and the one slot is being sent */
    q->st.dropped++;
    q->st.dropped_bytes += len;
    goto out;
  }
  rc = append(q, msg, len);
out:
  pthread_mutex_unlock(&q->mu);
  return rc;
}

int vc_sendq_peek(vc_sendq* q, const uint8_t** data, size_t* len) {
  pthread_mutex_lock(&q->mu);
  int rc = 0;
  if (q->count > 0) {
    *data = q->slots[q->head].buf;
    *len = q->slots[q->head].len;
    q->peeked = true;
    rc = 1;
  }
  pthread_mutex_unlock(&q->mu);
  return rc;
}

void vc_sendq_pop(vc_sendq* q) {
  pthread_mutex_lock(&q->mu);
  if (q->count > 0) {
    q->bytes -= q->slots[q->head].len;
    q->head = (q->head + 1) % q->max_msgs;
    q->count--;
    q->st.sent++;
  }
  q->peeked = false;
  pthread_mutex_unlock(&q->mu);
}

void vc_sendq_clear(vc_sendq* q) {
  pthread_mutex_lock(&q->mu);
  q->peeked = false;
  while (q->count > 0) drop_oldest(q);
  pthread_mutex_unlock(&q->mu);
}

int vc_sendq_wait(vc_sendq* q, int timeout_ms) {
  pthread_mutex_lock(&q->mu);
  const struct timespec deadline = vc_clock_deadline_ns(timeout_ms > 0 ? (uint64_t)timeout_ms * 1000000u : 0);
  while (q->count == 0 && !q->woken) {
    if (timeout_ms < 0) {
      pthread_cond_wait(&q->cv, &q->mu);
    } else if (pthread_cond_timedwait(&q->cv, &q->mu, &deadline) == ETIMEDOUT) {
      break;
    }
  }
  q->woken = false;
  int rc = q->count > 0;
  pthread_mutex_unlock(&q->mu);
  return rc;
}

void vc_sendq_wake(vc_sendq* q) {
  pthread_mutex_lock(&q->mu);
  q->woken = true;
  pthread_cond_broadcast(&q->cv);
  pthread_mutex_unlock(&q->mu);
}

void vc_sendq_get_stats(vc_sendq* q, vc_sendq_stats* stats) {
  pthread_mutex_lock(&q->mu);
  *stats = q->st;
  stats->queued = q->count;
  stats->queued_bytes = q->bytes;
  pthread_mutex_unlock(&q->mu);
}
