/* The "udp" trigger backend: the emulated trigger. The host sends one 24-byte trigger datagram per
 * pulse (proto/SPEC.md) to every edge; this backend binds a UDP port (loopback by default), decodes
 * each datagram, drops undecodable and repeated ones, and counts pulses lost on the wire from gaps in
 * seq (a 64-pulse window tells a late datagram from a lost one; a jump back by more than that is the
 * host restarting its count). A jump ahead by more than VC_SEQ_MAX_JUMP is dropped unless the next
 * datagram confirms it, and a sender other than the host's address (when known) is dropped: one
 * forged datagram cannot move the edge's seq. The datagram's t_ns is the host's CLOCK_MONOTONIC: in
 * the emulated rig host and edges share one machine, so it needs no conversion. With the rig key
 * (protocol 2.3) only version-2 datagrams are taken, whose MAC verifies under the trigger key and
 * whose counter is past the last one taken: a stranger can neither forge nor replay a pulse. While a
 * key rotation is under way (next_key) a datagram under either key is taken, on one counter. */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "trigger_backend.h"
#include "voxcap/auth.h"
#include "voxcap/proto.h"

struct udp_priv {
  int fd;
  bool keyed;
  vc_mac mac; /* with keyed: the trigger key and the next counter taken */
  bool has_next;
  vc_mac mac_next; /* with has_next: the trigger key of the rig's next key (a rotation under way) */
  vc_seq_window window;
  bool check_source;
  struct in_addr source; /* with check_source: the only sender taken */
};

static void udp_free(void* p) {
  struct udp_priv* u = p;
  if (!u) return;
  if (u->fd >= 0) close(u->fd);
  memset(&u->mac, 0, sizeof u->mac);
  memset(&u->mac_next, 0, sizeof u->mac_next);
  free(u);
}

static int udp_open(vc_trigger* trig, const vc_trigger_config* cfg, vc_trigger_info* info, void** out) {
  const char* addr = cfg->bind_address ? cfg->bind_address : "127.0.0.1";
  char src[96];
  struct sockaddr_in sa;
  socklen_t salen = sizeof sa;
  struct udp_priv* u;
  int rc;
  snprintf(src, sizeof src, "%s:%u", addr, cfg->port);
  vc_trigger_set_source(trig, src);
  memset(&sa, 0, sizeof sa);
  sa.sin_family = AF_INET;
  sa.sin_port = htons(cfg->port);
  if (inet_pton(AF_INET, addr, &sa.sin_addr) != 1)
    return vc_trigger_set_error(trig, -EINVAL, "bind_address must be an IPv4 address such as 127.0.0.1");
  u = calloc(1, sizeof *u);
  if (!u) return vc_trigger_set_error(trig, -ENOMEM, "out of memory");
  u->fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (u->fd < 0) {
    rc = vc_trigger_set_error(trig, -errno, "socket: %s", strerror(errno));
    goto err;
  }
  if (bind(u->fd, (struct sockaddr*)&sa, sizeof sa) != 0) {
    rc = vc_trigger_set_error(trig, -errno, "cannot bind: %s", strerror(errno));
    goto err;
  }
  if (getsockname(u->fd, (struct sockaddr*)&sa, &salen) != 0) {
    rc = vc_trigger_set_error(trig, -errno, "getsockname: %s", strerror(errno));
    goto err;
  }
  if (cfg->key) {
    if (vc_auth_init() < 0) {
      rc = vc_trigger_set_error(trig, -EIO, "libsodium failed to start");
      goto err;
    }
    vc_auth_trigger_key(cfg->key, &u->mac);
    u->keyed = true;
    if (cfg->next_key) {
      vc_auth_trigger_key(cfg->next_key, &u->mac_next);
      u->has_next = true;
    }
  }
  if (cfg->source_address && cfg->source_address[0]) {
    const char* src_addr = strcmp(cfg->source_address, "localhost") == 0 ? "127.0.0.1" : cfg->source_address;
    if (inet_pton(AF_INET, src_addr, &u->source) == 1) u->check_source = true;
  }
  info->port = ntohs(sa.sin_port);
  snprintf(info->source, sizeof info->source, "%s:%u", addr, info->port);
  *out = u;
  return 0;
err:
  udp_free(u);
  return rc;
}

static int udp_wait(vc_trigger* trig, void* p, int timeout_ms, vc_pulse* pulse, vc_trigger_stats* st) {
  struct udp_priv* u = p;
  uint64_t deadline = timeout_ms > 0 ? vc_clock_monotonic_ns() + (uint64_t)timeout_ms * 1000000ull : 0;
  for (;;) {
    uint8_t buf[64];
    struct sockaddr_in from;
    socklen_t fromlen = sizeof from;
    ssize_t n = recvfrom(u->fd, buf, sizeof buf, 0, (struct sockaddr*)&from, &fromlen);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK)
        return vc_trigger_set_error(trig, -errno, "recv: %s", strerror(errno));
      int wait_ms = timeout_ms;
      if (timeout_ms > 0) {
        uint64_t now = vc_clock_monotonic_ns();
        if (now >= deadline) return -ETIMEDOUT;
        wait_ms = (int)((deadline - now + 999999) / 1000000);
      }
      if (timeout_ms == 0) return -ETIMEDOUT;
      struct pollfd pfd = {.fd = u->fd, .events = POLLIN};
      int pr = poll(&pfd, 1, wait_ms);
      if (pr < 0 && errno != EINTR) return vc_trigger_set_error(trig, -errno, "poll: %s", strerror(errno));
      if (pr == 0) return -ETIMEDOUT;
      continue;
    }
    uint64_t seq, t_ns;
    if (u->check_source && (fromlen < sizeof from || from.sin_addr.s_addr != u->source.s_addr)) {
      st->foreign++;
      continue;
    }
    if (u->keyed) {
      int mrc = vc_trigger_dgram_decode_mac(buf, (size_t)n, &u->mac, &seq, &t_ns);
      /* During a key rotation the host pulses under either key; one counter for both, so a datagram
       * taken under one key cannot be replayed under the other. */
      if (mrc == VC_PROTO_EMAC && u->has_next)
        mrc = vc_trigger_dgram_decode_mac(buf, (size_t)n, &u->mac_next, &seq, &t_ns);
      if (mrc == 0 && u->has_next) {
        uint64_t c = u->mac.counter > u->mac_next.counter ? u->mac.counter : u->mac_next.counter;
        u->mac.counter = u->mac_next.counter = c;
      }
      if (mrc != 0) {
        st->forged++;
        continue;
      }
    } else if (vc_trigger_dgram_decode(buf, (size_t)n, &seq, &t_ns) != 0) {
      st->invalid++;
      continue;
    }
    int64_t lost_delta;
    switch (vc_seq_window_push(&u->window, seq, &lost_delta)) {
      case VC_SEQ_DUPLICATE:
        st->duplicate++;
        continue;
      case VC_SEQ_JUMP:
        st->jumps++;
        st->last_jump_seq = seq;
        continue;
      case VC_SEQ_LATE:
        st->late++;
        break;
      case VC_SEQ_NEXT:
      case VC_SEQ_RESTART:
        break;
    }
    st->lost = (uint64_t)((int64_t)st->lost + lost_delta);
    pulse->seq = seq;
    pulse->t_ns = t_ns;
    return 0;
  }
}

static int udp_fd(const void* p) {
  return ((const struct udp_priv*)p)->fd;
}

const vc_trigger_backend vc_trigger_backend_udp = {
    .name = "udp", .open = udp_open, .wait = udp_wait, .fd = udp_fd, .free_priv = udp_free};
