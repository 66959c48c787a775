/* The daemon's frame pairs and queues (see frameq.h). */
#include "frameq.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "voxcap/why.h"
enum { SLOT_FREE = 0, SLOT_FILLED, SLOT_MATCHED, SLOT_WORK };

struct vc_frameq {
  vc_pairer* pairer;
  unsigned nslots;
  uint8_t slot[VC_FRAMEQ_CAMS][VC_FRAMEQ_MAX_SLOTS]; /* SLOT_* */
  struct {
    bool used;
    uint64_t seq;
    int slot[VC_FRAMEQ_CAMS];
  } pend[VC_FRAMEQ_PEND]; /* pulses with some frames matched, not yet complete */
  vc_frame_pair work[VC_FRAMEQ_WORK];
  unsigned work_head, work_count;
  bool open, time_capture;
  uint64_t min_seq;
  uint64_t now_ns; /* of the call the pairer's events come from */
  uint64_t work_drops, slot_drops[VC_FRAMEQ_CAMS];
  uint64_t capture_sum_ns, capture_max_ns, capture_n;
};

static int pend_find(vc_frameq* q, uint64_t seq, bool create) {
  int free_i = -1;
  for (int i = 0; i < VC_FRAMEQ_PEND; i++) {
    if (q->pend[i].used && q->pend[i].seq == seq) return i;
    if (!q->pend[i].used && free_i < 0) free_i = i;
  }
  if (!create || free_i < 0) return -1;
  q->pend[free_i].used = true;
  q->pend[free_i].seq = seq;
  q->pend[free_i].slot[0] = q->pend[free_i].slot[1] = -1;
  return free_i;
}

static void free_slot(vc_frameq* q, unsigned cam, int s) {
  if (s >= 0) q->slot[cam][s] = SLOT_FREE;
}

static void complete(vc_frameq* q, const vc_pair_event* ev) {
  int i = pend_find(q, ev->seq, false);
  if (i < 0) return;
  if (q->work_count == VC_FRAMEQ_WORK) { /* the pipeline is behind: drop the oldest pair */
    vc_frame_pair* old = &q->work[q->work_head];
    for (unsigned c = 0; c < VC_FRAMEQ_CAMS; c++) free_slot(q, c, old->slot[c]);
    q->work_head = (q->work_head + 1) % VC_FRAMEQ_WORK;
    q->work_count--;
    q->work_drops++;
  }
  vc_frame_pair* w = &q->work[(q->work_head + q->work_count) % VC_FRAMEQ_WORK];
  w->seq = ev->seq;
  w->t_ns = ev->pulse_t_ns;
  w->paired_ns = q->now_ns;
  if (q->time_capture) { /* the capture stage: trigger edge -> both frames in memory */
    uint64_t lat = q->now_ns - ev->pulse_t_ns;
    q->capture_sum_ns += lat;
    if (lat > q->capture_max_ns) q->capture_max_ns = lat;
    q->capture_n++;
  }
  for (unsigned c = 0; c < VC_FRAMEQ_CAMS; c++) {
    w->slot[c] = q->pend[i].slot[c];
    q->slot[c][w->slot[c]] = SLOT_WORK;
  }
  q->work_count++;
  q->pend[i].used = false;
}

static void on_pair(void* user, const vc_pair_event* ev) {
  vc_frameq* q = user;
  int i;
  switch (ev->type) {
    case VC_PAIR_MATCHED:
      i = pend_find(q, ev->seq, true);
      if (i < 0) { /* more pending pulses than the table holds: cannot happen with pulse_slots < PEND */
        free_slot(q, ev->cam, (int)ev->cookie);
        break;
      }
      q->pend[i].slot[ev->cam] = (int)ev->cookie;
      q->slot[ev->cam][ev->cookie] = SLOT_MATCHED;
      break;
    case VC_PAIR_COMPLETE:
      complete(q, ev);
      break;
    case VC_PAIR_PULSE_UNMATCHED:
      i = pend_find(q, ev->seq, false);
      if (i >= 0) {
        for (unsigned c = 0; c < VC_FRAMEQ_CAMS; c++) free_slot(q, c, q->pend[i].slot[c]);
        q->pend[i].used = false;
      }
      break;
    case VC_PAIR_FRAME_UNMATCHED:
      free_slot(q, ev->cam, (int)ev->cookie);
      break;
  }
}

int vc_frameq_new(const vc_pairing_config* pairing, unsigned nslots, vc_frameq** out, char* why,
                  size_t why_len) {
  const char* bad = NULL;
  int rc;
  vc_frameq* q;
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if (!pairing || !out) {
    vc_why(why, why_len, "frame queue: invalid arguments");
    return -EINVAL;
  }
  if (nslots < 1 || nslots > VC_FRAMEQ_MAX_SLOTS)
    bad = "frame slots must be 1..8";
  else if (pairing->ncams != VC_FRAMEQ_CAMS)
    bad = "pairing must be for two cameras";
  else if (pairing->frame_slots < nslots)
    bad = "the pairer must hold as many frames per camera as there are slots";
  else if (pairing->pulse_slots >= VC_FRAMEQ_PEND)
    bad = "the pairer's pulse slots must be fewer than 32";
  else if ((rc = vc_pairing_config_check(pairing, why, why_len)) < 0)
    return rc;
  if (bad) {
    vc_why(why, why_len, "frame queue: %s", bad);
    return -EINVAL;
  }
  q = calloc(1, sizeof *q);
  if (!q) {
    vc_why(why, why_len, "frame queue: out of memory");
    return -ENOMEM;
  }
  q->nslots = nslots;
  char pwhy[160];
  rc = vc_pairer_new(pairing, on_pair, q, &q->pairer, pwhy, sizeof pwhy);
  if (rc < 0) goto err_free;
  *out = q;
  return 0;

err_free:
  vc_why(why, why_len, "frame queue: %s", pwhy);
  free(q);
  return rc;
}

void vc_frameq_free(vc_frameq* q) {
  if (!q) return;
  vc_pairer_free(q->pairer);
  free(q);
}

void vc_frameq_reset(vc_frameq* q, bool open, uint64_t min_seq, bool time_capture) {
  vc_pairer_flush(q->pairer); /* frames and pulses of the previous phase are no use now */
  q->work_head = q->work_count = 0;
  memset(q->slot, 0, sizeof(q->slot));
  memset(q->pend, 0, sizeof(q->pend));
  q->open = open;
  q->min_seq = min_seq;
  q->time_capture = time_capture;
}

bool vc_frameq_is_open(const vc_frameq* q) {
  return q->open;
}

int vc_frameq_acquire(vc_frameq* q, unsigned cam) {
  if (!q->open) return -EAGAIN;
  for (unsigned i = 0; i < q->nslots; i++)
    if (q->slot[cam][i] == SLOT_FREE) {
      q->slot[cam][i] = SLOT_FILLED;
      return (int)i;
    }
  q->slot_drops[cam]++;
  return -EBUSY;
}

void vc_frameq_add_frame(vc_frameq* q, unsigned cam, int slot, uint64_t t_ns, uint64_t now_ns) {
  q->now_ns = now_ns;
  vc_pairer_add_frame(q->pairer, cam, t_ns, (uint64_t)slot);
}

bool vc_frameq_add_pulse(vc_frameq* q, uint64_t seq, uint64_t t_ns, uint64_t now_ns) {
  if (!q->open || seq < q->min_seq) return false;
  q->now_ns = now_ns;
  vc_pairer_add_pulse(q->pairer, seq, t_ns);
  return true;
}

void vc_frameq_advance(vc_frameq* q, uint64_t now_ns) {
  q->now_ns = now_ns;
  vc_pairer_advance(q->pairer, now_ns);
}

bool vc_frameq_pop(vc_frameq* q, vc_frame_pair* out) {
  if (q->work_count == 0) return false;
  *out = q->work[q->work_head];
  q->work_head = (q->work_head + 1) % VC_FRAMEQ_WORK;
  q->work_count--;
  return true;
}

unsigned vc_frameq_ready(const vc_frameq* q) {
  return q->work_count;
}

void vc_frameq_done(vc_frameq* q, const vc_frame_pair* pair) {
  /* The phase may have changed (slots reset) while the pipeline worked; only free what is still its. */
  for (unsigned c = 0; c < VC_FRAMEQ_CAMS; c++)
    if (q->slot[c][pair->slot[c]] == SLOT_WORK) q->slot[c][pair->slot[c]] = SLOT_FREE;
}

void vc_frameq_take_capture_time(vc_frameq* q, uint64_t* sum_ns, uint64_t* max_ns, uint64_t* n) {
  *sum_ns = q->capture_sum_ns;
  *max_ns = q->capture_max_ns;
  *n = q->capture_n;
  q->capture_sum_ns = q->capture_max_ns = q->capture_n = 0;
}

void vc_frameq_get_stats(const vc_frameq* q, vc_frameq_stats* out) {
  memset(out, 0, sizeof(*out));
  out->work_drops = q->work_drops;
  for (unsigned c = 0; c < VC_FRAMEQ_CAMS; c++) out->slot_drops[c] = q->slot_drops[c];
  vc_pairer_get_stats(q->pairer, &out->pairing);
}
