/* The edge daemon's run loop (see edged.h for the thread structure). */
#define _GNU_SOURCE
#include "edged.h"

#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "node.h"
#include "voxcap/edge/clock.h"
#include "voxcap/edge/pairing.h"

#define MAX_SLOTS 8
#define PEND 32
#define WORK 8
#define INBOUND 8

enum { SLOT_FREE = 0, SLOT_FILLED, SLOT_MATCHED, SLOT_WORK };

typedef struct slot {
  uint8_t* rgb;
  size_t stride;
  int state;
} slot;

typedef struct edged edged;

typedef struct camthread {
  edged* d;
  int idx;
  vc_camera* cam;
  bool emulated;
  int width, height;
  pthread_t th;
  bool started;
  atomic_bool run;
  slot slots[MAX_SLOTS];
  /* Emulated cameras: the pulse to expose next, handed over by the trigger thread (under d->mu). Like
   * a real sensor still busy with its last frame, a camera that has not taken the previous pulse
   * when the next one comes misses it (counted): stale pulses are never queued. */
  vc_pulse pending;
  bool has_pending;
  uint64_t missed_pulses;
  pthread_cond_t mbox_cv;
  uint64_t last_frame_ms;
  uint64_t frames, errors, slot_drops;
  char last_error[256];
} camthread;

typedef struct ctl {
  uint16_t type;
  uint64_t seq;
  uint32_t frames;
  vc_config cfg;
} ctl;

typedef struct work_item {
  uint64_t seq, t_ns;
  int slot[2];
} work_item;

typedef enum phase { PH_IDLE = 0, PH_BACKGROUND, PH_RUNNING } phase;

struct edged {
  const vc_edged_options* opt;
  pthread_mutex_t mu;
  pthread_cond_t cv;
  vc_pairer* pairer;
  camthread cams[2];
  unsigned nslots;
  vc_trigger* trig;
  pthread_t trig_th;
  atomic_bool trig_run;
  struct {
    bool used;
    uint64_t seq;
    int slot[2];
  } pend[PEND];
  work_item work[WORK];
  unsigned work_head, work_count;
  ctl inbound[INBOUND];
  unsigned in_head, in_count;
  phase ph;            /* under mu: which frames and pulses go to the pairer */
  uint64_t emu_seq_base; /* emulated cameras show frame seq - base; pulses below it are ignored */
  uint64_t last_pulse_seq;
  vc_node* node;
  atomic_uint node_state;
  vc_link* link;
  uint64_t work_drops, hulls_sent, frame_sum_ns, frame_max_ns, frame_n;
  uint64_t capture_sum_ns, capture_max_ns, capture_n; /* under mu: pulse -> both frames paired, running */
};

static atomic_bool g_stop;
void vc_edged_request_stop(void) { atomic_store(&g_stop, true); }

static uint64_t mono_ms(void) { return vc_clock_monotonic_ns() / 1000000u; }

static int g_verbosity;
static void logm(int level, const char* fmt, ...) __attribute__((format(printf, 2, 3)));
static void logm(int level, const char* fmt, ...) {
  /* level 0 error, 1 warning, 2 info, 3 debug */
  if (level > g_verbosity + 1) return;
  static const char* names[] = {"error", "warning", "info", "debug"};
  char line[600];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(line, sizeof(line), fmt, ap);
  va_end(ap);
  fprintf(stderr, "voxcap-edge: %s: %s\n", names[level], line);
}

static void send_error(edged* d, uint32_t code, uint16_t severity, uint16_t about, const char* fmt, ...)
    __attribute__((format(printf, 5, 6)));
static void send_error(edged* d, uint32_t code, uint16_t severity, uint16_t about, const char* fmt, ...) {
  char text[VC_PROTO_MAX_ERROR_TEXT];
  va_list ap;
  va_start(ap, fmt);
  int n = vsnprintf(text, sizeof(text), fmt, ap);
  va_end(ap);
  if (n < 0) return;
  logm(severity == VC_SEVERITY_WARNING ? 1 : 0, "%s", text);
  if (!d->link) return;
  uint8_t buf[VC_PROTO_HEADER_SIZE + 16 + VC_PROTO_MAX_ERROR_TEXT];
  size_t len = 0;
  vc_header hdr = {.node_id = d->opt->node_id};
  vc_error e = {.code = code,
                .severity = severity,
                .about_type = about,
                .text_len = (uint16_t)((size_t)n < sizeof(text) ? (size_t)n : sizeof(text) - 1),
                .text = text};
  if (vc_encode_error(buf, sizeof(buf), &len, &hdr, &e) == 0) vc_link_send(d->link, buf, len);
}

/* ---- pairing (callbacks run under d->mu) ------------------------------------------------------ */

static int pend_find(edged* d, uint64_t seq, bool create) {
  int free_i = -1;
  for (int i = 0; i < PEND; i++) {
    if (d->pend[i].used && d->pend[i].seq == seq) return i;
    if (!d->pend[i].used && free_i < 0) free_i = i;
  }
  if (!create || free_i < 0) return -1;
  d->pend[free_i].used = true;
  d->pend[free_i].seq = seq;
  d->pend[free_i].slot[0] = d->pend[free_i].slot[1] = -1;
  return free_i;
}

static void free_slot(edged* d, int cam, int s) {
  if (s >= 0) d->cams[cam].slots[s].state = SLOT_FREE;
}

static void on_pair(void* user, const vc_pair_event* ev) {
  edged* d = user;
  int i;
  switch (ev->type) {
    case VC_PAIR_MATCHED:
      i = pend_find(d, ev->seq, true);
      if (i < 0) { /* more pending pulses than the table holds: cannot happen with pulse_slots < PEND */
        free_slot(d, (int)ev->cam, (int)ev->cookie);
        break;
      }
      d->pend[i].slot[ev->cam] = (int)ev->cookie;
      d->cams[ev->cam].slots[ev->cookie].state = SLOT_MATCHED;
      break;
    case VC_PAIR_COMPLETE: {
      i = pend_find(d, ev->seq, false);
      if (i < 0) break;
      if (d->work_count == WORK) { /* the pipeline is behind: drop the oldest pair */
        work_item* old = &d->work[d->work_head];
        free_slot(d, 0, old->slot[0]);
        free_slot(d, 1, old->slot[1]);
        d->work_head = (d->work_head + 1) % WORK;
        d->work_count--;
        d->work_drops++;
      }
      work_item* w = &d->work[(d->work_head + d->work_count) % WORK];
      w->seq = ev->seq;
      w->t_ns = ev->pulse_t_ns;
      if (d->ph == PH_RUNNING) { /* the capture stage: trigger edge -> both frames in memory */
        uint64_t lat = vc_clock_monotonic_ns() - ev->pulse_t_ns;
        d->capture_sum_ns += lat;
        if (lat > d->capture_max_ns) d->capture_max_ns = lat;
        d->capture_n++;
      }
      for (int c = 0; c < 2; c++) {
        w->slot[c] = d->pend[i].slot[c];
        d->cams[c].slots[w->slot[c]].state = SLOT_WORK;
      }
      d->work_count++;
      d->pend[i].used = false;
      pthread_cond_signal(&d->cv);
      break;
    }
    case VC_PAIR_PULSE_UNMATCHED:
      i = pend_find(d, ev->seq, false);
      if (i >= 0) {
        free_slot(d, 0, d->pend[i].slot[0]);
        free_slot(d, 1, d->pend[i].slot[1]);
        d->pend[i].used = false;
      }
      logm(3, "pulse %llu: no frame from camera mask 0x%x", (unsigned long long)ev->seq, ev->missing_mask);
      break;
    case VC_PAIR_FRAME_UNMATCHED:
      free_slot(d, (int)ev->cam, (int)ev->cookie);
      break;
  }
}

/* ---- camera threads ----------------------------------------------------------------------------- */

static void* cam_main(void* arg) {
  camthread* ct = arg;
  edged* d = ct->d;
  ct->last_frame_ms = mono_ms();
  bool reported = false;
  while (atomic_load(&ct->run)) {
    if (ct->emulated) {
      /* An emulated camera exposes a frame only when "triggered": wait for the next pulse. */
      pthread_mutex_lock(&d->mu);
      if (!ct->has_pending) {
        struct timespec dl;
        clock_gettime(CLOCK_MONOTONIC, &dl);
        dl.tv_nsec += 50 * 1000000L;
        if (dl.tv_nsec >= 1000000000L) {
          dl.tv_sec++;
          dl.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&ct->mbox_cv, &d->mu, &dl);
      }
      if (!ct->has_pending) {
        pthread_mutex_unlock(&d->mu);
        continue;
      }
      vc_pulse p = ct->pending;
      ct->has_pending = false;
      pthread_mutex_unlock(&d->mu);
      int rc = vc_camera_soft_trigger(ct->cam, p.seq, p.t_ns);
      if (rc < 0) {
        snprintf(ct->last_error, sizeof(ct->last_error), "%s", vc_camera_last_error(ct->cam));
        send_error(d, VC_ERR_CAMERA, VC_SEVERITY_ERROR, 0, "camera %d: %s", ct->idx, ct->last_error);
        continue;
      }
    }
    vc_frame f;
    int rc = vc_camera_capture(ct->cam, 100, &f);
    if (rc == -ETIMEDOUT) {
      int limit = d->opt->camera_timeout_ms ? d->opt->camera_timeout_ms : 2000;
      pthread_mutex_lock(&d->mu);
      bool active = d->ph != PH_IDLE;
      pthread_mutex_unlock(&d->mu);
      if (active && !reported && mono_ms() - ct->last_frame_ms > (uint64_t)limit) {
        send_error(d, VC_ERR_CAMERA, VC_SEVERITY_ERROR, 0, "camera %d (%s): stopped delivering frames for %d ms",
                   ct->idx, d->opt->cameras[ct->idx].device ? d->opt->cameras[ct->idx].device : "?", limit);
        ct->errors++;
        reported = true;
      }
      continue;
    }
    if (rc < 0) {
      ct->errors++;
      send_error(d, VC_ERR_CAMERA, VC_SEVERITY_ERROR, 0, "camera %d: %s", ct->idx, vc_camera_last_error(ct->cam));
      usleep(100 * 1000);
      continue;
    }
    ct->last_frame_ms = mono_ms();
    reported = false;
    ct->frames++;
    pthread_mutex_lock(&d->mu);
    if (d->ph != PH_IDLE) {
      int s = -1;
      for (unsigned i = 0; i < d->nslots; i++)
        if (ct->slots[i].state == SLOT_FREE) {
          s = (int)i;
          break;
        }
      if (s < 0) {
        ct->slot_drops++; /* the pipeline holds every slot: it is behind */
      } else {
        slot* sl = &ct->slots[s];
        size_t row = (size_t)ct->width * 3;
        for (int y = 0; y < ct->height; y++) memcpy(sl->rgb + (size_t)y * row, f.rgb + (size_t)y * f.stride, row);
        sl->state = SLOT_FILLED;
        vc_pairer_add_frame(d->pairer, (unsigned)ct->idx, f.t_ns, (uint64_t)s);
      }
    }
    pthread_mutex_unlock(&d->mu);
    vc_camera_release(ct->cam, &f);
  }
  return NULL;
}

/* ---- trigger thread ----------------------------------------------------------------------------- */

static void* trig_main(void* arg) {
  edged* d = arg;
  while (atomic_load(&d->trig_run)) {
    vc_pulse p;
    int rc = vc_trigger_wait(d->trig, 100, &p);
    if (rc == -ETIMEDOUT) continue;
    if (rc < 0) {
      send_error(d, VC_ERR_TRIGGER, VC_SEVERITY_ERROR, 0, "trigger: %s", vc_trigger_last_error(d->trig));
      usleep(100 * 1000);
      continue;
    }
    pthread_mutex_lock(&d->mu);
    d->last_pulse_seq = p.seq;
    if (d->ph != PH_IDLE && p.seq >= d->emu_seq_base) {
      vc_pairer_add_pulse(d->pairer, p.seq, p.t_ns);
      for (int c = 0; c < 2; c++) {
        camthread* ct = &d->cams[c];
        if (!ct->emulated) continue;
        if (ct->has_pending) ct->missed_pulses++; /* still busy with the previous one */
        ct->pending = p;
        ct->has_pending = true;
        pthread_cond_signal(&ct->mbox_cv);
      }
    }
    pthread_mutex_unlock(&d->mu);
  }
  return NULL;
}

/* ---- cameras: open, reopen (emulated), threads -------------------------------------------------- */

static bool is_emulated(const vc_camera_config* c) {
  return c->backend && (strcmp(c->backend, "file") == 0 || strcmp(c->backend, "sim") == 0);
}

static int open_camera(const vc_camera_config* base, bool background, uint64_t seq_base, vc_camera** out) {
  vc_camera_config cfg = *base;
  if (is_emulated(base)) {
    cfg.external_trigger = true;
    cfg.background = background;
    cfg.loop = background;
    cfg.seq_base = seq_base;
  }
  char why[256] = "";
  int rc = vc_camera_open(&cfg, out, why, sizeof(why));
  if (rc < 0) {
    logm(0, "camera %d (%s %s): %s", base->index, base->backend, base->device ? base->device : "", why);
    return rc;
  }
  rc = vc_camera_start(*out);
  if (rc < 0) {
    logm(0, "camera %d: cannot start: %s", base->index, vc_camera_last_error(*out));
    vc_camera_free(*out);
    *out = NULL;
  }
  return rc;
}

static void cams_stop_threads(edged* d) {
  for (int c = 0; c < 2; c++) {
    camthread* ct = &d->cams[c];
    if (!ct->started) continue;
    atomic_store(&ct->run, false);
    pthread_mutex_lock(&d->mu);
    pthread_cond_broadcast(&ct->mbox_cv);
    pthread_mutex_unlock(&d->mu);
    pthread_join(ct->th, NULL);
    ct->started = false;
  }
}

static int cams_start_threads(edged* d) {
  for (int c = 0; c < 2; c++) {
    camthread* ct = &d->cams[c];
    atomic_store(&ct->run, true);
    int rc = pthread_create(&ct->th, NULL, cam_main, ct);
    if (rc != 0) return -rc;
    ct->started = true;
  }
  return 0;
}

/* Emulated cameras: reopen for the phase. Real cameras stay as they are. Pipeline thread only. */
static int cams_enter_phase(edged* d, phase ph, uint64_t seq_base) {
  bool any_emulated = d->cams[0].emulated || d->cams[1].emulated;
  if (any_emulated) cams_stop_threads(d);
  pthread_mutex_lock(&d->mu);
  d->ph = ph;
  vc_pairer_flush(d->pairer); /* frames and pulses of the previous phase are no use now */
  d->work_head = d->work_count = 0;
  for (int c = 0; c < 2; c++) {
    d->cams[c].has_pending = false;
    for (unsigned s = 0; s < d->nslots; s++) d->cams[c].slots[s].state = SLOT_FREE;
  }
  memset(d->pend, 0, sizeof(d->pend));
  d->emu_seq_base = any_emulated ? seq_base : 0;
  pthread_mutex_unlock(&d->mu);
  if (!any_emulated) return 0;
  for (int c = 0; c < 2; c++) {
    camthread* ct = &d->cams[c];
    if (!ct->emulated) continue;
    vc_camera_free(ct->cam);
    ct->cam = NULL;
    int rc = open_camera(&d->opt->cameras[c], ph == PH_BACKGROUND, seq_base, &ct->cam);
    if (rc < 0) {
      send_error(d, VC_ERR_CAMERA, VC_SEVERITY_ERROR, 0, "camera %d: cannot reopen", c);
      return rc;
    }
  }
  return cams_start_threads(d);
}

/* ---- the link's callbacks (link thread) ---------------------------------------------------------- */

static void on_message(void* user, const vc_msg* m) {
  edged* d = user;
  if (!m->known) {
    logm(2, "ignoring a message of unknown type %u from the host", m->hdr.type);
    return;
  }
  switch (m->hdr.type) {
    case VC_MSG_CONFIG:
    case VC_MSG_BACKGROUND:
    case VC_MSG_START:
    case VC_MSG_STOP:
      break;
    case VC_MSG_HEARTBEAT:
      return;
    case VC_MSG_ERROR:
      logm(1, "host says: %.*s", (int)m->u.error.text_len, m->u.error.text);
      return;
    default:
      logm(1, "unexpected %s from the host", vc_msg_type_name(m->hdr.type));
      return;
  }
  pthread_mutex_lock(&d->mu);
  if (d->in_count == INBOUND) {
    pthread_mutex_unlock(&d->mu);
    logm(0, "too many host commands pending; dropping %s", vc_msg_type_name(m->hdr.type));
    return;
  }
  ctl* c = &d->inbound[(d->in_head + d->in_count) % INBOUND];
  c->type = m->hdr.type;
  c->seq = m->hdr.seq;
  if (m->hdr.type == VC_MSG_CONFIG) c->cfg = m->u.config;
  if (m->hdr.type == VC_MSG_BACKGROUND) c->frames = m->u.background.frame_count;
  d->in_count++;
  pthread_cond_signal(&d->cv);
  pthread_mutex_unlock(&d->mu);
}

static void on_connection(void* user, bool up) {
  edged* d = user;
  logm(up ? 2 : 1, "host connection %s", up ? "up" : "down");
  (void)d;
}

static uint32_t node_state_cb(void* user) {
  edged* d = user;
  return atomic_load(&d->node_state);
}

static void link_log(void* user, int level, const char* line) {
  (void)user;
  logm(level == 0 ? 2 : (level == 1 ? 1 : 0), "link: %s", line);
}

/* ---- the pipeline thread ------------------------------------------------------------------------- */

/* Publishes the node state and, when it changed, tells the host at once (a HEARTBEAT out of turn):
 * the host drives the session on these changes, and waiting for the periodic heartbeat would add up
 * to a heartbeat period to every step of a (re)join. */
static void publish_state(edged* d) {
  uint32_t st = vc_node_state(d->node);
  if (atomic_exchange(&d->node_state, st) == st || !d->link) return;
  uint8_t buf[VC_PROTO_HEADER_SIZE + 32];
  size_t len = 0;
  vc_header hdr = {.node_id = d->opt->node_id};
  vc_heartbeat hb = {.sender_time_ns = vc_clock_monotonic_ns(), .state = st};
  if (vc_encode_heartbeat(buf, sizeof(buf), &len, &hdr, &hb) == 0) vc_link_send(d->link, buf, len);
}

static void handle_ctl(edged* d, ctl* c) {
  char why[256] = "", warn[256] = "";
  int rc;
  switch (c->type) {
    case VC_MSG_CONFIG:
      if (d->ph != PH_IDLE) cams_enter_phase(d, PH_IDLE, 0);
      rc = vc_node_configure(d->node, &c->cfg, why, sizeof(why), warn, sizeof(warn));
      if (rc < 0) {
        send_error(d, VC_ERR_CONFIG, VC_SEVERITY_ERROR, VC_MSG_CONFIG, "CONFIG rejected: %s", why);
      } else {
        if (warn[0]) send_error(d, VC_ERR_CONFIG, VC_SEVERITY_WARNING, VC_MSG_CONFIG, "%s", warn);
        logm(2, "configured: grid %ux%ux%u (id %u)", c->cfg.grid.nx, c->cfg.grid.ny, c->cfg.grid.nz,
             c->cfg.grid_id);
      }
      break;
    case VC_MSG_BACKGROUND:
      rc = vc_node_background_begin(d->node, c->frames);
      if (rc < 0) {
        send_error(d, VC_ERR_STATE, VC_SEVERITY_ERROR, VC_MSG_BACKGROUND, "BACKGROUND before CONFIG");
        break;
      }
      pthread_mutex_lock(&d->mu);
      uint64_t base = d->last_pulse_seq + 1;
      pthread_mutex_unlock(&d->mu);
      cams_enter_phase(d, PH_BACKGROUND, base);
      logm(2, "learning the background");
      break;
    case VC_MSG_START:
      rc = vc_node_start(d->node, c->seq);
      if (rc < 0) {
        send_error(d, VC_ERR_STATE, VC_SEVERITY_ERROR, VC_MSG_START, "START before the background was learnt");
        break;
      }
      cams_enter_phase(d, PH_RUNNING, c->seq);
      logm(2, "running from seq %llu", (unsigned long long)c->seq);
      break;
    case VC_MSG_STOP:
      vc_node_stop(d->node);
      cams_enter_phase(d, PH_IDLE, 0);
      logm(2, "stopped");
      break;
  }
  publish_state(d);
}

static void handle_work(edged* d, const work_item* w) {
  const uint8_t* rgb[2] = {d->cams[0].slots[w->slot[0]].rgb, d->cams[1].slots[w->slot[1]].rgb};
  const size_t stride[2] = {d->cams[0].slots[w->slot[0]].stride, d->cams[1].slots[w->slot[1]].stride};
  uint32_t st = vc_node_state(d->node);
  if (st == VC_STATE_BACKGROUND) {
    int rc = vc_node_background_add(d->node, rgb, stride);
    if (rc == 1) {
      logm(2, "background learnt");
      if (d->opt->state_dir) {
        int src = vc_node_save_background(d->node, d->opt->state_dir);
        if (src < 0) logm(1, "cannot keep the background model in %s: %s", d->opt->state_dir, strerror(-src));
      }
      cams_enter_phase(d, PH_IDLE, 0);
    } else if (rc < 0) {
      send_error(d, VC_ERR_INTERNAL, VC_SEVERITY_ERROR, VC_MSG_BACKGROUND, "background learning failed: %s",
                 strerror(-rc));
    }
  } else if (st == VC_STATE_RUNNING) {
    const uint8_t* msg = NULL;
    size_t len = 0;
    int rc = vc_node_process(d->node, w->seq, w->t_ns, rgb, stride, &msg, &len);
    if (rc == 0) {
      if (vc_link_send(d->link, msg, len) == 0) d->hulls_sent++;
      uint64_t lat = vc_clock_monotonic_ns() - w->t_ns;
      d->frame_sum_ns += lat;
      if (lat > d->frame_max_ns) d->frame_max_ns = lat;
      d->frame_n++;
    } else if (rc < 0 && rc != -EAGAIN) {
      send_error(d, VC_ERR_OVERLOAD, VC_SEVERITY_WARNING, 0, "frame %llu not sent: %s",
                 (unsigned long long)w->seq, vc_proto_strerror(rc));
    }
  }
  publish_state(d);
}

/* Appends a stage record (mean and max over n frames) and resets the accumulators. */
static void put_stage(vc_stats* s, int* k, uint32_t id, uint64_t* sum_ns, uint64_t* max_ns, uint64_t* n) {
  if (*n == 0) return;
  uint64_t mean = *sum_ns / *n;
  s->stages[*k].stage_id = id;
  s->stages[*k].mean_ns = mean > UINT32_MAX ? UINT32_MAX : (uint32_t)mean;
  s->stages[*k].max_ns = *max_ns > UINT32_MAX ? UINT32_MAX : (uint32_t)*max_ns;
  (*k)++;
  *sum_ns = *max_ns = *n = 0;
}

static void send_stats(edged* d) {
  vc_stats s;
  memset(&s, 0, sizeof(s));
  int k = vc_node_take_stage_times(d->node, s.stages, VC_PROTO_MAX_STAGES - 2, &s.frames);
  pthread_mutex_lock(&d->mu);
  put_stage(&s, &k, VC_STAGE_CAPTURE, &d->capture_sum_ns, &d->capture_max_ns, &d->capture_n);
  pthread_mutex_unlock(&d->mu);
  put_stage(&s, &k, VC_STAGE_FRAME, &d->frame_sum_ns, &d->frame_max_ns, &d->frame_n);
  s.stage_count = (uint16_t)k;
  vc_pairing_stats ps;
  vc_node_counters nc;
  vc_link_stats ls;
  pthread_mutex_lock(&d->mu);
  vc_pairer_get_stats(d->pairer, &ps);
  uint64_t frames = d->cams[0].frames + d->cams[1].frames;
  uint64_t cam_errors = d->cams[0].errors + d->cams[1].errors;
  uint64_t drops = d->work_drops + d->cams[0].slot_drops + d->cams[1].slot_drops;
  pthread_mutex_unlock(&d->mu);
  vc_node_get_counters(d->node, &nc);
  vc_link_get_stats(d->link, &ls);
  struct {
    uint32_t id;
    uint64_t v;
  } c[] = {
      {VC_COUNTER_FRAMES_CAPTURED, frames},
      {VC_COUNTER_HULLS_SENT, d->hulls_sent},
      {VC_COUNTER_SEND_QUEUE_DROPS, ls.queue_dropped + drops},
      {VC_COUNTER_FRAMES_WITHOUT_PULSE, ps.frames_without_pulse[0] + ps.frames_without_pulse[1]},
      {VC_COUNTER_PULSES_WITHOUT_FRAME, ps.pulses_without_frame[0] + ps.pulses_without_frame[1]},
      {VC_COUNTER_HULLS_OVER_LIMIT, nc.hulls_over_limit},
      {VC_COUNTER_CAMERA_ERRORS, cam_errors},
  };
  for (size_t i = 0; i < sizeof(c) / sizeof(c[0]); i++) {
    s.counters[i].counter_id = c[i].id;
    s.counters[i].value = c[i].v;
  }
  s.counter_count = (uint16_t)(sizeof(c) / sizeof(c[0]));
  uint8_t buf[VC_PROTO_HEADER_SIZE + 1024];
  size_t len = 0;
  vc_header hdr = {.node_id = d->opt->node_id};
  if (vc_encode_stats(buf, sizeof(buf), &len, &hdr, &s) == 0) vc_link_send(d->link, buf, len);
}

static uint32_t fourcc_of(vc_pixfmt f) {
  switch (f) {
    case VC_PIXFMT_YUYV: return VC_FOURCC('Y', 'U', 'Y', 'V');
    case VC_PIXFMT_UYVY: return VC_FOURCC('U', 'Y', 'V', 'Y');
    case VC_PIXFMT_GREY: return VC_FOURCC('G', 'R', 'E', 'Y');
    case VC_PIXFMT_BGR24: return VC_FOURCC('B', 'G', 'R', '3');
    default: return VC_FOURCC('R', 'G', 'B', '3');
  }
}

static void teardown(edged* d) {
  atomic_store(&d->trig_run, false);
  if (d->trig_th) pthread_join(d->trig_th, NULL);
  cams_stop_threads(d);
  vc_link_stop(d->link);
  for (int c = 0; c < 2; c++) {
    vc_camera_free(d->cams[c].cam);
    for (unsigned s = 0; s < MAX_SLOTS; s++) free(d->cams[c].slots[s].rgb);
    pthread_cond_destroy(&d->cams[c].mbox_cv);
  }
  vc_trigger_free(d->trig);
  vc_pairer_free(d->pairer);
  vc_node_free(d->node);
  pthread_mutex_destroy(&d->mu);
  pthread_cond_destroy(&d->cv);
}

int vc_edged_run(const vc_edged_options* opt) {
  g_verbosity = opt->verbosity;
  edged* d = calloc(1, sizeof(*d));
  if (!d) return -ENOMEM;
  d->opt = opt;
  d->nslots = opt->frame_slots ? (opt->frame_slots > MAX_SLOTS ? MAX_SLOTS : opt->frame_slots) : 4;
  pthread_mutex_init(&d->mu, NULL);
  pthread_condattr_t ca;
  pthread_condattr_init(&ca);
  pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
  pthread_cond_init(&d->cv, &ca);
  for (int c = 0; c < 2; c++) pthread_cond_init(&d->cams[c].mbox_cv, &ca);
  pthread_condattr_destroy(&ca);
  int rc;

  char why[256] = "";
  if ((rc = vc_trigger_open(&opt->trigger, &d->trig, why, sizeof(why))) < 0) {
    logm(0, "trigger: %s", why);
    goto out;
  }
  vc_trigger_info ti;
  vc_trigger_get_info(d->trig, &ti);
  logm(2, "trigger: %s %s", ti.backend, ti.source);

  vc_node_camera ncam[2];
  for (int c = 0; c < 2; c++) {
    camthread* ct = &d->cams[c];
    ct->d = d;
    ct->idx = c;
    ct->emulated = is_emulated(&opt->cameras[c]);
    if ((rc = open_camera(&opt->cameras[c], false, 0, &ct->cam)) < 0) goto out;
    vc_camera_info ci;
    vc_camera_get_info(ct->cam, &ci);
    ct->width = ci.width;
    ct->height = ci.height;
    for (unsigned s = 0; s < d->nslots; s++) {
      ct->slots[s].stride = (size_t)ci.width * 3;
      ct->slots[s].rgb = malloc(ct->slots[s].stride * (size_t)ci.height);
      if (!ct->slots[s].rgb) {
        rc = -ENOMEM;
        goto out;
      }
    }
    ncam[c].width = ci.width;
    ncam[c].height = ci.height;
    ncam[c].pixel_format = fourcc_of(ci.pixfmt);
    ncam[c].max_fps_milli = ci.fps_num ? (uint32_t)((uint64_t)ci.fps_num * 1000u / (ci.fps_den ? ci.fps_den : 1)) : 0;
    logm(2, "camera %d: %s %s %dx%d (%s)", c, ci.backend, ci.device, ci.width, ci.height, ci.driver);
  }

  vc_pairing_config pc;
  vc_pairing_config_init(&pc);
  pc.ncams = 2;
  if (opt->pair_tolerance_ns) pc.tolerance_ns = opt->pair_tolerance_ns;
  if (opt->pair_max_delay_ns) pc.max_delay_ns = opt->pair_max_delay_ns;
  pc.pulse_slots = 16;
  pc.frame_slots = d->nslots;
  for (int c = 0; c < 2; c++) pc.latency_ns[c] = opt->camera_latency_ns[c];
  if ((rc = vc_pairing_config_check(&pc, why, sizeof(why))) < 0 ||
      (rc = vc_pairer_new(&pc, on_pair, d, &d->pairer)) < 0) {
    logm(0, "pairing: %s", why[0] ? why : strerror(-rc));
    goto out;
  }

  d->node = vc_node_new(opt->node_id, ncam);
  if (!d->node) {
    rc = -errno;
    logm(0, "node: %s", strerror(errno));
    goto out;
  }
  if (opt->state_dir) {
    int lrc = vc_node_load_background(d->node, opt->state_dir, why, sizeof(why));
    if (lrc == 0)
      logm(2, "restored the background model kept in %s", opt->state_dir);
    else if (lrc != -ENOENT)
      logm(1, "not restoring the background model: %s", why);
  }
  atomic_store(&d->node_state, vc_node_state(d->node));
  uint8_t hello[VC_PROTO_HEADER_SIZE + 256];
  size_t hello_len = 0;
  uint32_t caps = VC_CAP_HULL | (strcmp(opt->trigger.backend, "udp") == 0 ? VC_CAP_UDP_TRIGGER : VC_CAP_GPIO_TRIGGER);
  if ((rc = vc_node_hello(d->node, caps, hello, sizeof(hello), &hello_len)) < 0) goto out;
  vc_link_config lc = opt->link;
  lc.node_id = opt->node_id;
  vc_link_callbacks cb = {.on_message = on_message, .on_connection = on_connection, .state = node_state_cb,
                          .log = link_log, .user = d};
  if ((rc = vc_link_start(&lc, &cb, hello, hello_len, &d->link)) < 0) {
    logm(0, "link: %s", strerror(-rc));
    goto out;
  }
  if ((rc = cams_start_threads(d)) < 0) goto out;
  atomic_store(&d->trig_run, true);
  if ((rc = -pthread_create(&d->trig_th, NULL, trig_main, d)) < 0) {
    d->trig_th = 0;
    goto out;
  }

  int stats_ms = opt->stats_ms ? opt->stats_ms : 1000;
  uint64_t last_stats = mono_ms();
  while (!atomic_load(&g_stop)) {
    pthread_mutex_lock(&d->mu);
    if (d->work_count == 0 && d->in_count == 0) {
      struct timespec dl;
      clock_gettime(CLOCK_MONOTONIC, &dl);
      dl.tv_nsec += 10 * 1000000L;
      if (dl.tv_nsec >= 1000000000L) {
        dl.tv_sec++;
        dl.tv_nsec -= 1000000000L;
      }
      pthread_cond_timedwait(&d->cv, &d->mu, &dl);
    }
    vc_pairer_advance(d->pairer, vc_clock_monotonic_ns());
    bool have_ctl = d->in_count > 0, have_work = false;
    ctl c;
    work_item w;
    if (have_ctl) {
      c = d->inbound[d->in_head];
      d->in_head = (d->in_head + 1) % INBOUND;
      d->in_count--;
    } else if (d->work_count > 0) {
      w = d->work[d->work_head];
      d->work_head = (d->work_head + 1) % WORK;
      d->work_count--;
      have_work = true;
    }
    pthread_mutex_unlock(&d->mu);
    if (have_ctl) handle_ctl(d, &c);
    if (have_work) {
      handle_work(d, &w);
      pthread_mutex_lock(&d->mu);
      /* The phase may have changed (slots reset) while we worked; only free what is still ours. */
      for (int k = 0; k < 2; k++)
        if (d->cams[k].slots[w.slot[k]].state == SLOT_WORK) d->cams[k].slots[w.slot[k]].state = SLOT_FREE;
      pthread_mutex_unlock(&d->mu);
    }
    if (mono_ms() - last_stats >= (uint64_t)stats_ms) {
      if (vc_link_connected(d->link)) send_stats(d);
      last_stats = mono_ms();
    }
  }
  rc = 0;
  {
    vc_pairing_stats ps;
    vc_pairer_get_stats(d->pairer, &ps);
    logm(2, "stopping: frames %llu + %llu, pulses %llu (complete %llu, incomplete %llu), emulated exposures "
            "missed %llu + %llu, hulls sent %llu",
         (unsigned long long)d->cams[0].frames, (unsigned long long)d->cams[1].frames,
         (unsigned long long)ps.pulses, (unsigned long long)ps.complete, (unsigned long long)ps.incomplete,
         (unsigned long long)d->cams[0].missed_pulses, (unsigned long long)d->cams[1].missed_pulses,
         (unsigned long long)d->hulls_sent);
  }
out:
  teardown(d);
  free(d);
  return rc;
}

int vc_edged_check(const vc_edged_options* opt) {
  int failures = 0;
  char why[256];
  for (int c = 0; c < 2; c++) {
    vc_camera* cam = NULL;
    why[0] = '\0';
    int rc = vc_camera_open(&opt->cameras[c], &cam, why, sizeof(why));
    if (rc < 0) {
      printf("camera %d: FAIL %s\n", c, why);
      failures++;
      continue;
    }
    vc_camera_info ci;
    vc_camera_get_info(cam, &ci);
    printf("camera %d: ok %s %s %dx%d %s (%s)\n", c, ci.backend, ci.device, ci.width, ci.height,
           vc_pixfmt_name(ci.pixfmt) ? vc_pixfmt_name(ci.pixfmt) : "?", ci.driver);
    vc_camera_free(cam);
  }
  vc_trigger* trig = NULL;
  why[0] = '\0';
  if (vc_trigger_open(&opt->trigger, &trig, why, sizeof(why)) < 0) {
    printf("trigger: FAIL %s\n", why);
    failures++;
  } else {
    vc_trigger_info ti;
    vc_trigger_get_info(trig, &ti);
    printf("trigger: ok %s %s\n", ti.backend, ti.source);
    vc_trigger_free(trig);
  }
  printf("host: %s:%u\n", opt->link.host, opt->link.port);
  return failures ? -EINVAL : 0;
}
