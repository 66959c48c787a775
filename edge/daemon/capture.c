/* The edge's capture threads and frame slots (see capture.h). */
#define _GNU_SOURCE
#include "capture.h"

#include "log.h"

#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "voxcap/edge/clock.h"
#include "voxcap/proto.h"
#include "voxcap/why.h"

typedef struct camthread {
  vc_capture* cap;
  int idx;
  vc_camera* cam;
  const vc_camera_config* cfg;
  bool soft_trigger; /* VC_CAMERA_CAP_SOFT_TRIGGER: exposes only when the trigger thread says so */
  bool rewind;       /* VC_CAMERA_CAP_REWIND: restarted at every phase */
  int width, height;
  pthread_t th;
  bool started;
  atomic_bool run;
  uint8_t* slot_rgb[VC_FRAMEQ_MAX_SLOTS];
  size_t stride;
  /* Soft-triggered cameras: the pulse to expose next, handed over by the trigger thread (under
   * cap->mu). Like a real sensor still busy with its last frame, a camera that has not taken the
   * previous pulse when the next one comes misses it (counted): stale pulses are never queued. */
  vc_pulse pending;
  bool has_pending;
  uint64_t missed_pulses;
  pthread_cond_t mbox_cv;
  uint64_t last_frame_ms;
  uint64_t frames, errors;
} camthread;

struct vc_capture {
  vc_capture_options opt;
  vc_capture_callbacks cb;
  pthread_mutex_t mu;
  pthread_cond_t cv;   /* a pair is ready, or a wake */
  bool wake;           /* under mu */
  vc_frameq* q;        /* under mu */
  vc_capture_phase ph; /* under mu */
  camthread cams[VC_FRAMEQ_CAMS];
  unsigned nslots;
  vc_trigger* trig;
  pthread_t trig_th;
  bool trig_started;
  atomic_bool trig_run;
  uint64_t last_pulse_seq; /* under mu */
};

static uint64_t mono_ms(void) {
  return vc_clock_monotonic_ns() / 1000000u;
}

static void errorf(vc_capture* cap, uint32_t code, const char* fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void errorf(vc_capture* cap, uint32_t code, const char* fmt, ...) {
  if (!cap->cb.error) return;
  char text[VC_PROTO_MAX_ERROR_TEXT];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(text, sizeof(text), fmt, ap);
  va_end(ap);
  cap->cb.error(cap->cb.user, code, text);
}

/* An absolute MONOTONIC deadline for the condition variables (all made with CLOCK_MONOTONIC). */
static struct timespec deadline_in_ms(int ms) {
  return vc_clock_deadline_ns(ms > 0 ? (uint64_t)ms * 1000000u : 0);
}

/* ---- camera threads ----------------------------------------------------------------------------- */

static void* cam_main(void* arg) {
  camthread* ct = arg;
  vc_capture* cap = ct->cap;
  ct->last_frame_ms = mono_ms();
  bool reported = false;
  while (atomic_load(&ct->run)) {
    if (ct->soft_trigger) {
      /* This camera exposes a frame only when triggered: wait for the next pulse. */
      pthread_mutex_lock(&cap->mu);
      if (!ct->has_pending) {
        const struct timespec dl = deadline_in_ms(50);
        pthread_cond_timedwait(&ct->mbox_cv, &cap->mu, &dl);
      }
      if (!ct->has_pending) {
        pthread_mutex_unlock(&cap->mu);
        continue;
      }
      vc_pulse p = ct->pending;
      ct->has_pending = false;
      pthread_mutex_unlock(&cap->mu);
      int rc = vc_camera_soft_trigger(ct->cam, p.seq, p.t_ns);
      if (rc < 0) {
        errorf(cap, VC_ERR_CAMERA, "camera %d: %s", ct->idx, vc_camera_last_error(ct->cam));
        continue;
      }
    }
    vc_frame f;
    int rc = vc_camera_capture(ct->cam, 100, &f);
    if (rc == -ETIMEDOUT) {
      int limit = cap->opt.camera_timeout_ms ? cap->opt.camera_timeout_ms : 2000;
      pthread_mutex_lock(&cap->mu);
      bool active = cap->ph != VC_CAPTURE_IDLE;
      pthread_mutex_unlock(&cap->mu);
      if (active && !reported && mono_ms() - ct->last_frame_ms > (uint64_t)limit) {
        errorf(cap, VC_ERR_CAMERA, "camera %d (%s): stopped delivering frames for %d ms", ct->idx,
               ct->cfg->device ? ct->cfg->device : "?", limit);
        ct->errors++;
        reported = true;
      }
      continue;
    }
    if (rc < 0) {
      ct->errors++;
      errorf(cap, VC_ERR_CAMERA, "camera %d: %s", ct->idx, vc_camera_last_error(ct->cam));
      usleep(100 * 1000);
      continue;
    }
    ct->last_frame_ms = mono_ms();
    reported = false;
    ct->frames++;
    pthread_mutex_lock(&cap->mu);
    int s =
        vc_frameq_acquire(cap->q, (unsigned)ct->idx); /* -EBUSY: the pipeline holds every slot (counted) */
    if (s >= 0) {
      uint8_t* dst = ct->slot_rgb[s];
      size_t row = (size_t)ct->width * 3;
      for (int y = 0; y < ct->height; y++)
        memcpy(dst + (size_t)y * ct->stride, f.rgb + (size_t)y * f.stride, row);
      vc_frameq_add_frame(cap->q, (unsigned)ct->idx, s, f.t_ns, vc_clock_monotonic_ns());
      if (vc_frameq_ready(cap->q)) pthread_cond_signal(&cap->cv);
    }
    pthread_mutex_unlock(&cap->mu);
    vc_camera_release(ct->cam, &f);
  }
  return NULL;
}

/* ---- trigger thread ----------------------------------------------------------------------------- */

/* Datagrams the trigger dropped as forged (a seq jump, a foreign sender): a warning when their count
 * grows, at most one a second, so an attack is seen in the edge's log without flooding it. */
static void log_trigger_drops(vc_capture* cap, uint64_t* logged, uint64_t* last_ns) {
  vc_trigger_stats st;
  vc_trigger_get_stats(cap->trig, &st);
  uint64_t n = st.jumps + st.foreign + st.forged, now = vc_clock_monotonic_ns();
  if (n == *logged || (*last_ns && now - *last_ns < 1000000000ull)) return;
  vc_log(
      VC_LOG_WARN,
      "trigger: dropped %llu datagrams so far: %llu with a seq jump beyond %u pulses (last seq %llu), %llu "
      "from another sender than the host, %llu without a valid MAC or replayed (forged)",
      (unsigned long long)n, (unsigned long long)st.jumps, VC_SEQ_MAX_JUMP,
      (unsigned long long)st.last_jump_seq, (unsigned long long)st.foreign, (unsigned long long)st.forged);
  *logged = n;
  *last_ns = now;
}

static void* trig_main(void* arg) {
  vc_capture* cap = arg;
  uint64_t drops_logged = 0, drops_logged_ns = 0;
  while (atomic_load(&cap->trig_run)) {
    vc_pulse p;
    int rc = vc_trigger_wait(cap->trig, 100, &p);
    log_trigger_drops(cap, &drops_logged, &drops_logged_ns);
    if (rc == -ETIMEDOUT) continue;
    if (rc < 0) {
      errorf(cap, VC_ERR_TRIGGER, "trigger: %s", vc_trigger_last_error(cap->trig));
      usleep(100 * 1000);
      continue;
    }
    pthread_mutex_lock(&cap->mu);
    cap->last_pulse_seq = p.seq;
    if (vc_frameq_add_pulse(cap->q, p.seq, p.t_ns, vc_clock_monotonic_ns())) {
      if (vc_frameq_ready(cap->q)) pthread_cond_signal(&cap->cv);
      for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
        camthread* ct = &cap->cams[c];
        if (!ct->soft_trigger) continue;
        if (ct->has_pending) ct->missed_pulses++; /* still busy with the previous one */
        ct->pending = p;
        ct->has_pending = true;
        pthread_cond_signal(&ct->mbox_cv);
      }
    }
    pthread_mutex_unlock(&cap->mu);
  }
  return NULL;
}

/* ---- cameras: open, rewind, threads ------------------------------------------------------------- */

static int open_camera(const vc_camera_config* base, vc_camera** out, char* why, size_t why_len) {
  char cwhy[256] = "";
  int rc = vc_camera_open(base, out, cwhy, sizeof(cwhy));
  if (rc < 0) {
    vc_why(why, why_len, "camera %d (%s %s): %s", base->index, base->backend,
           base->device ? base->device : "", cwhy);
    return rc;
  }
  rc = vc_camera_start(*out);
  if (rc < 0) {
    vc_why(why, why_len, "camera %d: cannot start: %s", base->index, vc_camera_last_error(*out));
    vc_camera_free(*out);
    *out = NULL;
  }
  return rc;
}

static void cams_stop_threads(vc_capture* cap) {
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
    camthread* ct = &cap->cams[c];
    if (!ct->started) continue;
    atomic_store(&ct->run, false);
    pthread_mutex_lock(&cap->mu);
    pthread_cond_broadcast(&ct->mbox_cv);
    pthread_mutex_unlock(&cap->mu);
    pthread_join(ct->th, NULL);
    ct->started = false;
  }
}

static int cams_start_threads(vc_capture* cap) {
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
    camthread* ct = &cap->cams[c];
    atomic_store(&ct->run, true);
    int rc = pthread_create(&ct->th, NULL, cam_main, ct);
    if (rc != 0) return -rc;
    ct->started = true;
  }
  return 0;
}

int vc_capture_set_phase(vc_capture* cap, vc_capture_phase ph, uint64_t seq_base) {
  bool any_rewind = cap->cams[0].rewind || cap->cams[1].rewind;
  if (any_rewind) cams_stop_threads(cap);
  pthread_mutex_lock(&cap->mu);
  cap->ph = ph;
  /* a rewound camera shows frame seq − seq_base: earlier pulses have no frame */
  vc_frameq_reset(cap->q, ph != VC_CAPTURE_IDLE, any_rewind ? seq_base : 0, ph == VC_CAPTURE_RUNNING);
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) cap->cams[c].has_pending = false;
  pthread_mutex_unlock(&cap->mu);
  if (!any_rewind) return 0;
  /* Cameras that play a sequence (emulated ones) restart it for the phase: the empty scene while the
   * host learns the background, else the performer from seq_base on, so that every node shows the same
   * frame for the same pulse. Cameras of the real room stay as they are. */
  vc_camera_scene scene = ph == VC_CAPTURE_BACKGROUND ? VC_CAMERA_SCENE_EMPTY : VC_CAMERA_SCENE_LIVE;
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
    camthread* ct = &cap->cams[c];
    if (!ct->rewind) continue;
    int rc = vc_camera_stop(ct->cam);
    if (rc == 0) rc = vc_camera_rewind(ct->cam, seq_base, scene);
    if (rc == 0) rc = vc_camera_start(ct->cam);
    if (rc < 0) {
      errorf(cap, VC_ERR_CAMERA, "camera %d: cannot restart its sequence: %s", c,
             vc_camera_last_error(ct->cam));
      return rc;
    }
  }
  return cams_start_threads(cap);
}

/* ---- lifecycle ---------------------------------------------------------------------------------- */

int vc_capture_new(const vc_capture_options* opt, const vc_capture_callbacks* cb, vc_capture** out, char* why,
                   size_t why_len) {
  int rc;
  char part[256] = "";
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if (!opt || !opt->trigger || !out) {
    vc_why(why, why_len, "capture: invalid arguments");
    return -EINVAL;
  }
  vc_capture* cap = calloc(1, sizeof(*cap));
  if (!cap) {
    vc_why(why, why_len, "capture: out of memory");
    return -ENOMEM;
  }
  cap->opt = *opt;
  if (cb) cap->cb = *cb;
  cap->nslots = opt->frame_slots
                    ? (opt->frame_slots > VC_FRAMEQ_MAX_SLOTS ? VC_FRAMEQ_MAX_SLOTS : opt->frame_slots)
                    : 4;
  pthread_mutex_init(&cap->mu, NULL);
  pthread_condattr_t ca;
  pthread_condattr_init(&ca);
  pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
  pthread_cond_init(&cap->cv, &ca);
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) pthread_cond_init(&cap->cams[c].mbox_cv, &ca);
  pthread_condattr_destroy(&ca);

  if ((rc = vc_trigger_open(opt->trigger, &cap->trig, part, sizeof(part))) < 0) {
    vc_why(why, why_len, "trigger: %s", part);
    goto err;
  }
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
    camthread* ct = &cap->cams[c];
    ct->cap = cap;
    ct->idx = c;
    ct->cfg = &cap->opt.cameras[c];
    if ((rc = open_camera(ct->cfg, &ct->cam, why, why_len)) < 0) goto err;
    uint32_t caps = vc_camera_caps(ct->cam);
    ct->soft_trigger = (caps & VC_CAMERA_CAP_SOFT_TRIGGER) != 0;
    ct->rewind = (caps & VC_CAMERA_CAP_REWIND) != 0;
    vc_camera_info ci;
    vc_camera_get_info(ct->cam, &ci);
    ct->width = ci.width;
    ct->height = ci.height;
    ct->stride = (size_t)ci.width * 3;
    for (unsigned s = 0; s < cap->nslots; s++) {
      ct->slot_rgb[s] = malloc(ct->stride * (size_t)ci.height);
      if (!ct->slot_rgb[s]) {
        rc = -ENOMEM;
        vc_why(why, why_len, "camera %d: out of memory for %u frame slots", ct->cfg->index, cap->nslots);
        goto err;
      }
    }
  }

  vc_pairing_config pc = opt->pairing;
  pc.ncams = VC_FRAMEQ_CAMS;
  pc.pulse_slots = 16;
  pc.frame_slots = cap->nslots;
  if ((rc = vc_frameq_new(&pc, cap->nslots, &cap->q, part, sizeof(part))) < 0) {
    vc_why(why, why_len, "pairing: %s", part);
    goto err;
  }
  *out = cap;
  return 0;

err:
  vc_capture_free(cap);
  return rc;
}

int vc_capture_start(vc_capture* cap) {
  int rc = cams_start_threads(cap);
  if (rc < 0) return rc;
  atomic_store(&cap->trig_run, true);
  if ((rc = pthread_create(&cap->trig_th, NULL, trig_main, cap)) != 0) return -rc;
  cap->trig_started = true;
  return 0;
}

void vc_capture_free(vc_capture* cap) {
  if (!cap) return;
  atomic_store(&cap->trig_run, false);
  if (cap->trig_started) pthread_join(cap->trig_th, NULL);
  cams_stop_threads(cap);
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
    vc_camera_free(cap->cams[c].cam);
    for (unsigned s = 0; s < VC_FRAMEQ_MAX_SLOTS; s++) free(cap->cams[c].slot_rgb[s]);
    pthread_cond_destroy(&cap->cams[c].mbox_cv);
  }
  vc_trigger_free(cap->trig);
  vc_frameq_free(cap->q);
  pthread_mutex_destroy(&cap->mu);
  pthread_cond_destroy(&cap->cv);
  free(cap);
}

void vc_capture_get_camera_info(const vc_capture* cap, int cam, vc_camera_info* info) {
  vc_camera_get_info(cap->cams[cam].cam, info);
}

void vc_capture_get_trigger_info(const vc_capture* cap, vc_trigger_info* info) {
  vc_trigger_get_info(cap->trig, info);
}

vc_capture_phase vc_capture_get_phase(vc_capture* cap) {
  pthread_mutex_lock(&cap->mu);
  vc_capture_phase ph = cap->ph;
  pthread_mutex_unlock(&cap->mu);
  return ph;
}

uint64_t vc_capture_last_pulse_seq(vc_capture* cap) {
  pthread_mutex_lock(&cap->mu);
  uint64_t seq = cap->last_pulse_seq;
  pthread_mutex_unlock(&cap->mu);
  return seq;
}

/* ---- the pipeline's side ------------------------------------------------------------------------ */

bool vc_capture_next(vc_capture* cap, int timeout_ms, vc_capture_pair* out) {
  pthread_mutex_lock(&cap->mu);
  if (vc_frameq_ready(cap->q) == 0 && !cap->wake) {
    const struct timespec dl = deadline_in_ms(timeout_ms);
    pthread_cond_timedwait(&cap->cv, &cap->mu, &dl);
  }
  cap->wake = false;
  vc_frameq_advance(cap->q, vc_clock_monotonic_ns());
  bool have = vc_frameq_pop(cap->q, &out->pair);
  pthread_mutex_unlock(&cap->mu);
  if (!have) return false;
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
    out->rgb[c] = cap->cams[c].slot_rgb[out->pair.slot[c]];
    out->stride[c] = cap->cams[c].stride;
  }
  return true;
}

void vc_capture_done(vc_capture* cap, const vc_capture_pair* pair) {
  pthread_mutex_lock(&cap->mu);
  vc_frameq_done(cap->q, &pair->pair);
  pthread_mutex_unlock(&cap->mu);
}

void vc_capture_wake(vc_capture* cap) {
  pthread_mutex_lock(&cap->mu);
  cap->wake = true;
  pthread_cond_signal(&cap->cv);
  pthread_mutex_unlock(&cap->mu);
}

void vc_capture_take_capture_time(vc_capture* cap, uint64_t* sum_ns, uint64_t* max_ns, uint64_t* n) {
  pthread_mutex_lock(&cap->mu);
  vc_frameq_take_capture_time(cap->q, sum_ns, max_ns, n);
  pthread_mutex_unlock(&cap->mu);
}

void vc_capture_get_stats(vc_capture* cap, vc_capture_stats* out) {
  memset(out, 0, sizeof(*out));
  pthread_mutex_lock(&cap->mu);
  for (int c = 0; c < VC_FRAMEQ_CAMS; c++) {
    out->frames[c] = cap->cams[c].frames;
    out->errors[c] = cap->cams[c].errors;
    out->missed_pulses[c] = cap->cams[c].missed_pulses;
  }
  vc_frameq_get_stats(cap->q, &out->queue);
  pthread_mutex_unlock(&cap->mu);
}
