/* vc_trigger: one interface over the edge's trigger inputs.
 *
 * Backends, chosen by name from the configuration (never by #ifdef):
 *   "gpiod"  a GPIO line wired to the host's trigger output: rising-edge events read through libgpiod
 *            (v2 API), kernel timestamps, pulses counted into seq from the kernel's per-line event counter
 *   "udp"    the emulated trigger: one datagram per pulse (proto's trigger datagram: seq + host
 *            CLOCK_MONOTONIC time), received on a loopback UDP port
 * Every pulse comes out as {seq, t_ns CLOCK_MONOTONIC}. Lost pulses are counted: gaps in the kernel's
 * event counter (gpiod: its event FIFO overflowed) or in the datagrams' seq (udp: lost on the wire).
 *
 * Errors: functions return 0 or a negative errno-style code and leave a one-line message naming the
 * backend and the chip/line or address in vc_trigger_last_error() (what the edge daemon forwards to
 * the host as ERROR). A vc_trigger is not thread-safe: one thread drives it.
 */
#ifndef VOXCAP_EDGE_TRIGGER_H
#define VOXCAP_EDGE_TRIGGER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/edge/clock.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_trigger vc_trigger;

typedef struct vc_pulse {
  uint64_t seq;  /* pulse counter (host's seq for udp; seq_base + kernel line counter − 1 for gpiod) */
  uint64_t t_ns; /* time of the pulse edge, CLOCK_MONOTONIC ns */
} vc_pulse;

typedef enum vc_trigger_bias {
  VC_TRIGGER_BIAS_AS_IS = 0,
  VC_TRIGGER_BIAS_DISABLED,
  VC_TRIGGER_BIAS_PULL_UP,
  VC_TRIGGER_BIAS_PULL_DOWN,
} vc_trigger_bias;

typedef struct vc_trigger_config {
  const char* backend; /* "gpiod" | "udp" (required) */
  /* gpiod */
  const char* chip;      /* "/dev/gpiochip0" or "gpiochip0" */
  const char* line_name; /* line by name (e.g. "GPIO17"), or NULL to use line_offset */
  unsigned line_offset;
  bool active_low; /* the pulse is a falling edge on the wire */
  vc_trigger_bias bias;
  unsigned debounce_us;    /* 0 = off */
  vc_clock_id event_clock; /* kernel clock of the edge timestamps: MONOTONIC (default) or REALTIME;
                              converted to MONOTONIC in vc_clock */
  uint64_t seq_base;       /* gpiod: seq of the first pulse after open */
  /* udp */
  const char* bind_address; /* NULL = "127.0.0.1" */
  /* The host's IPv4 address when it is known (the edge's host.address): datagrams from any other
   * sender are dropped (counted in foreign). NULL: any sender. */
  const char* source_address;
  uint16_t port; /* 0 = any free port (see vc_trigger_info.port) */
  /* udp: the rig key (VC_AUTH_KEY_SIZE bytes, copied at open) or NULL. With a key only version-2
   * datagrams whose MAC verifies, with a counter past the last one taken, are pulses (proto/SPEC.md
   * "Trigger datagram"); anything else is counted in forged. */
  const uint8_t* key;
  /* udp, with key: the rig's next key during a rotation (copied at open) or NULL; a datagram under
   * either key is a pulse (one counter for both). */
  const uint8_t* next_key;
} vc_trigger_config;

/* All zero except event_clock = MONOTONIC (which is zero). */
void vc_trigger_config_init(vc_trigger_config* cfg);

typedef struct vc_trigger_info {
  const char* backend; /* static string */
  char source[128];    /* "gpiochip0 line 17 (GPIO17)" or "127.0.0.1:47000" */
  uint16_t port;       /* udp: the bound port */
} vc_trigger_info;

/* udp: a seq more than this many pulses ahead of the last one is implausible (dropped unless the next
 * datagram follows it). */
#define VC_SEQ_MAX_JUMP 1024u

typedef struct vc_trigger_stats {
  uint64_t pulses;    /* pulses delivered */
  uint64_t lost;      /* pulses known to be missing (gaps in seq / kernel counter) */
  uint64_t late;      /* udp: datagrams that arrived after a later one (delivered, not lost) */
  uint64_t duplicate; /* udp: repeated seq (dropped) */
  uint64_t invalid;   /* udp: datagrams that failed to decode (dropped); gpiod: unexpected events */
  uint64_t jumps;     /* udp: datagrams whose seq jumped implausibly far ahead (dropped; VC_SEQ_MAX_JUMP) */
  uint64_t foreign;   /* udp: datagrams from another sender than source_address (dropped) */
  uint64_t forged;    /* udp with a key: datagrams without a valid MAC, or replayed (dropped) */
  uint64_t last_jump_seq; /* udp: the seq of the last datagram dropped as a jump */
} vc_trigger_stats;

/* Opens the input: validates cfg, picks the backend by name, requests the line / binds the socket.
 * On failure returns a negative code, *out = NULL and a one-line message in why (if given). */
int vc_trigger_open(const vc_trigger_config* cfg, vc_trigger** out, char* why, size_t why_len);
/* Waits up to timeout_ms (< 0: forever, 0: poll) for the next pulse. -ETIMEDOUT if none came. */
int vc_trigger_wait(vc_trigger* trig, int timeout_ms, vc_pulse* pulse);
/* A file descriptor that polls readable when vc_trigger_wait may have a pulse (owned by trig).
 * Pulses may also be buffered inside: after it polls readable, call vc_trigger_wait(trig, 0, ...)
 * until -ETIMEDOUT. */
int vc_trigger_fd(const vc_trigger* trig);
void vc_trigger_free(vc_trigger* trig);

const char* vc_trigger_last_error(const vc_trigger* trig);
int vc_trigger_last_errno(const vc_trigger* trig);
void vc_trigger_get_info(const vc_trigger* trig, vc_trigger_info* info);
void vc_trigger_get_stats(const vc_trigger* trig, vc_trigger_stats* stats);

/* Names of the compiled-in backends, NULL-terminated (static). */
const char* const* vc_trigger_backend_names(void);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_TRIGGER_H */
