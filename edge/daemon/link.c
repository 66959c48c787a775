/* The edge's TCP link to the host (see link.h). One thread; poll() on the socket and an eventfd that
 * senders and stop() signal. */
#define _GNU_SOURCE
#include "link.h"

#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <sodium.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include "log.h"
#include "sendq.h"
#include "voxcap/auth.h"
#include "voxcap/edge/clock.h"
#include "voxcap/why.h"

struct vc_link {
  vc_link_config cfg;
  char host[256];
  vc_link_callbacks cb;
  uint8_t* hello;
  size_t hello_len;
  vc_sendq* q;
  int wake_fd;
  pthread_t thread;
  atomic_bool running;
  atomic_bool connected;
  pthread_mutex_t mu; /* guards st */
  vc_link_stats st;
  bool keyed;
  uint8_t key[VC_AUTH_KEY_SIZE];
  bool has_next;
  uint8_t next_key[VC_AUTH_KEY_SIZE]; /* with has_next: the key a rotation brings (either is proved) */
  vc_mac tx;                          /* node -> host of the current connection (link thread only) */
  uint8_t* seal; /* the message being written, sealed (grown to the largest message, then reused) */
  size_t seal_cap;
};

static uint64_t mono_ms(void) {
  return vc_clock_monotonic_ns() / 1000000u;
}

static void stat_add(vc_link* l, uint64_t* field, uint64_t v) {
  pthread_mutex_lock(&l->mu);
  *field += v;
  pthread_mutex_unlock(&l->mu);
}

/* Waits up to ms, returning early when stop() is called. */
static void sleep_interruptible(vc_link* l, int ms) {
  struct pollfd p = {.fd = l->wake_fd, .events = POLLIN};
  uint64_t end = mono_ms() + (uint64_t)ms;
  while (atomic_load(&l->running)) {
    uint64_t now = mono_ms();
    if (now >= end) break;
    if (poll(&p, 1, (int)(end - now)) > 0) {
      uint64_t v;
      if (read(l->wake_fd, &v, sizeof(v)) < 0) { /* drained; loop re-checks running */
      }
    }
  }
}

static int connect_host(vc_link* l) {
  char port[8];
  snprintf(port, sizeof(port), "%u", l->cfg.port);
  struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM};
  struct addrinfo* res = NULL;
  int gai = getaddrinfo(l->host, port, &hints, &res);
  if (gai != 0) {
    vc_log(VC_LOG_ERROR, "link: cannot resolve host %s: %s", l->host, gai_strerror(gai));
    return -1;
  }
  int fd = -1;
  for (struct addrinfo* a = res; a; a = a->ai_next) {
    fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    if (connect(fd, a->ai_addr, a->ai_addrlen) == 0) break;
    close(fd);
    fd = -1;
  }
  freeaddrinfo(res);
  if (fd < 0) return -1;
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
  return fd;
}

/* Writes all of buf (blocking, bounded by 2 s of no progress). */
static int write_all(vc_link* l, int fd, const uint8_t* buf, size_t len) {
  size_t off = 0;
  while (off < len) {
    ssize_t n = send(fd, buf + off, len - off, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      off += (size_t)n;
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) return -errno;
    struct pollfd p = {.fd = fd, .events = POLLOUT};
    if (poll(&p, 1, 2000) == 0) return -ETIMEDOUT;
  }
  stat_add(l, &l->st.bytes_sent, len);
  return 0;
}

static void send_heartbeat(vc_link* l) {
  uint8_t buf[VC_PROTO_HEADER_SIZE + 32];
  size_t len = 0;
  vc_header hdr = {.node_id = l->cfg.node_id};
  vc_heartbeat hb = {.sender_time_ns = vc_clock_monotonic_ns(),
                     .state = l->cb.state ? l->cb.state(l->cb.user) : VC_STATE_IDLE};
  if (vc_encode_heartbeat(buf, sizeof(buf), &len, &hdr, &hb) == 0) vc_sendq_push(l->q, buf, len);
}

static void send_protocol_error(vc_link* l, int fd, const vc_proto_diag* d, uint16_t about) {
  uint8_t buf[VC_PROTO_HEADER_SIZE + 16 + 300];
  size_t len = 0;
  char text[300];
  int n = snprintf(text, sizeof(text), "%s: %s", vc_proto_error_name(d->code), d->detail);
  vc_header hdr = {.node_id = l->cfg.node_id};
  vc_error e = {.code = VC_ERR_PROTOCOL,
                .severity = VC_SEVERITY_ERROR,
                .about_type = about,
                .text_len = (uint16_t)(n < 0 ? 0 : (n >= (int)sizeof(text) ? sizeof(text) - 1 : (size_t)n)),
                .text = text};
  /* Through the queue: a direct write could land inside a partly written message. */
  if (vc_encode_error(buf, sizeof(buf), &len, &hdr, &e) == 0) vc_sendq_push(l->q, buf, len);
  (void)fd;
}

static int write_auth(vc_link* l, int fd, uint16_t step, const uint8_t* nonce, const uint8_t* proof) {
  uint8_t buf[VC_PROTO_HEADER_SIZE + 128];
  size_t len = 0;
  vc_header hdr = {.node_id = l->cfg.node_id};
  vc_auth_msg a = {.step = step};
  if (nonce) memcpy(a.nonce, nonce, VC_AUTH_NONCE_SIZE);
  if (proof) memcpy(a.proof, proof, VC_AUTH_PROOF_SIZE);
  int rc = vc_encode_auth(buf, sizeof buf, &len, &hdr, &a);
  return rc < 0 ? rc : write_all(l, fd, buf, len);
}

/* The host's AUTH response: checks its proof, proves ours, keys both directions. 0, or -EACCES with
 * the reason logged. */
static int finish_auth(vc_link* l, int fd, vc_decoder* dec, const vc_msg* m, const uint8_t* nonce_node) {
  if (m->hdr.type != VC_MSG_AUTH || m->u.auth.step != VC_AUTH_RESPONSE) {
    const char* name = vc_msg_type_name(m->hdr.type);
    vc_log(VC_LOG_WARN, "link: %s:%u did not prove the rig key (it sent %s first): not obeying it", l->host,
           l->cfg.port, name ? name : "an unknown message");
    return -EACCES;
  }
  const uint8_t* nonce_host = m->u.auth.nonce;
  /* During a rotation the host holds the old key or the new one: whichever it proved, this
   * connection proves and is keyed with that one (never neither). */
  const uint8_t* key = l->key;
  if (!vc_auth_verify(m->u.auth.proof, key, VC_AUTH_ROLE_HOST, l->cfg.node_id, nonce_node, nonce_host)) {
    key = l->has_next ? l->next_key : NULL;
    if (!key ||
        !vc_auth_verify(m->u.auth.proof, key, VC_AUTH_ROLE_HOST, l->cfg.node_id, nonce_node, nonce_host)) {
      vc_log(VC_LOG_WARN, "link: %s:%u answered with a wrong proof of the rig key: not obeying it", l->host,
             l->cfg.port);
      return -EACCES;
    }
    vc_log(VC_LOG_INFO, "link: %s:%u proved the rig's next key (rotation under way)", l->host, l->cfg.port);
  }
  uint8_t proof[VC_AUTH_PROOF_SIZE];
  vc_auth_prove(proof, key, VC_AUTH_ROLE_NODE, l->cfg.node_id, nonce_node, nonce_host);
  vc_mac rx;
  vc_auth_session(key, l->cfg.node_id, nonce_node, nonce_host, &l->tx, &rx);
  vc_decoder_set_mac(dec, &rx);
  sodium_memzero(&rx, sizeof rx);
  if (write_auth(l, fd, VC_AUTH_PROOF, NULL, proof) < 0) return -EIO;
  return 0;
}

/* The message at out[0..len) as it goes on the wire: sealed when the connection is authenticated. */
static const uint8_t* wire_bytes(vc_link* l, bool authed, const uint8_t* out, size_t* len) {
  if (!authed) return out;
  size_t need = *len + VC_AUTH_TRAILER_SIZE;
  if (need > l->seal_cap) {
    uint8_t* nb = realloc(l->seal, need);
    if (!nb) return NULL;
    l->seal = nb;
    l->seal_cap = need;
  }
  memcpy(l->seal, out, *len);
  if (vc_mac_seal(&l->tx, l->seal, *len, l->seal_cap, len) < 0) return NULL;
  return l->seal;
}

/* One connection, until it fails or stop() is called. Returns true when the host proved the key (or
 * the rig is keyless): a session happened and the backoff starts again from its minimum. */
static bool run_connection(vc_link* l, int fd) {
  vc_decoder* dec = NULL;
  char dec_why[128];
  if (vc_decoder_new(0, &dec, dec_why, sizeof(dec_why)) < 0) {
    vc_log(VC_LOG_ERROR, "link: %s", dec_why);
    return false;
  }
  uint8_t nonce_node[VC_AUTH_NONCE_SIZE];
  vc_auth_random(nonce_node, sizeof nonce_node);
  if (write_all(l, fd, l->hello, l->hello_len) < 0 ||
      (l->keyed && write_auth(l, fd, VC_AUTH_CHALLENGE, nonce_node, NULL) < 0)) {
    vc_log(VC_LOG_WARN, "link: sending HELLO to %s:%u failed", l->host, l->cfg.port);
    vc_decoder_free(dec);
    return false;
  }
  bool authed = !l->keyed, mac_on = false;
  uint64_t mac_rejects = 0;
  if (authed) {
    atomic_store(&l->connected, true);
    if (l->cb.on_connection) l->cb.on_connection(l->cb.user, true);
  }
  uint64_t last_rx = mono_ms(), last_hb = 0;
  const uint8_t* out = NULL;
  size_t out_len = 0, out_off = 0;
  uint8_t chunk[65536];
  const char* why = "stopped";
  while (atomic_load(&l->running)) {
    uint64_t now = mono_ms();
    if (authed && now - last_hb >= (uint64_t)l->cfg.heartbeat_ms) {
      send_heartbeat(l);
      last_hb = now;
    }
    if (now - last_rx > (uint64_t)l->cfg.host_timeout_ms) {
      why = "host silent for too long";
      break;
    }
    if (!out && vc_sendq_peek(l->q, &out, &out_len)) {
      out_off = 0;
      if (!(out = wire_bytes(l, mac_on, out, &out_len))) {
        why = "out of memory sealing a message";
        break;
      }
    }
    struct pollfd p[2] = {{.fd = fd, .events = (short)(POLLIN | (out ? POLLOUT : 0))},
                          {.fd = l->wake_fd, .events = POLLIN}};
    int timeout = l->cfg.heartbeat_ms;
    if (poll(p, 2, timeout) < 0 && errno != EINTR) {
      why = "poll failed";
      break;
    }
    if (p[1].revents & POLLIN) {
      uint64_t v;
      if (read(l->wake_fd, &v, sizeof(v)) < 0) { /* nothing to do: eventfd drained */
      }
    }
    if (p[0].revents & (POLLERR | POLLHUP) && !(p[0].revents & POLLIN)) {
      why = "connection reset";
      break;
    }
    if (p[0].revents & POLLIN) {
      ssize_t n = recv(fd, chunk, sizeof(chunk), MSG_DONTWAIT);
      if (n == 0) {
        why = "host closed the connection";
        break;
      }
      if (n < 0 && errno != EAGAIN && errno != EINTR) {
        why = "receive failed";
        break;
      }
      if (n > 0) {
        last_rx = mono_ms();
        stat_add(l, &l->st.bytes_received, (uint64_t)n);
        bool fatal = false;
        for (size_t off = 0, used = 0; off < (size_t)n && !fatal; off += used) {
          if (vc_decoder_feed(dec, chunk + off, (size_t)n - off, &used) < 0) {
            fatal = true;
            break;
          }
          vc_msg msg;
          int rc;
          while ((rc = vc_decoder_next(dec, &msg)) != 0) {
            if (rc > 0 && !authed) { /* the first message of a keyed link must be the host's proof */
              if (finish_auth(l, fd, dec, &msg, nonce_node) < 0) {
                stat_add(l, &l->st.auth_failures, 1);
                why = "the host did not prove the rig key";
                fatal = true;
                break;
              }
              authed = mac_on = true;
              vc_log(VC_LOG_INFO, "link: %s:%u proved the rig key", l->host, l->cfg.port);
              atomic_store(&l->connected, true);
              if (l->cb.on_connection) l->cb.on_connection(l->cb.user, true);
              continue;
            }
            if (rc > 0) {
              stat_add(l, &l->st.messages_received, 1);
              if (l->cb.on_message) l->cb.on_message(l->cb.user, &msg);
              continue;
            }
            const vc_proto_diag* d = vc_decoder_diag(dec);
            stat_add(l, &l->st.rejected, 1);
            if (rc == VC_PROTO_EMAC || rc == VC_PROTO_EREPLAY || rc == VC_PROTO_EORDER) {
              stat_add(l, &l->st.mac_rejected, 1);
              vc_log(VC_LOG_WARN, "link: dropped a message from the host: %s (%s)", vc_proto_error_name(rc),
                     d->detail);
              if (++mac_rejects >= VC_AUTH_MAX_REJECTS) {
                why = "too many messages failed their MAC";
                fatal = true;
                break;
              }
              continue;
            }
            vc_log(VC_LOG_WARN, "link: rejected a message from the host: %s (%s)", vc_proto_error_name(rc),
                   d->detail);
            if (vc_proto_error_is_fatal(rc)) {
              fatal = true;
              break;
            }
            send_protocol_error(l, fd, d, msg.hdr.type);
          }
        }
        if (fatal) {
          if (strcmp(why, "stopped") == 0) why = "undecodable bytes from the host";
          break;
        }
      }
    }
    if (out && (p[0].revents & POLLOUT)) {
      ssize_t n = send(fd, out + out_off, out_len - out_off, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0 && errno != EAGAIN && errno != EINTR) {
        why = "send failed";
        break;
      }
      if (n > 0) {
        out_off += (size_t)n;
        stat_add(l, &l->st.bytes_sent, (uint64_t)n);
        if (out_off == out_len) {
          vc_sendq_pop(l->q);
          out = NULL;
        }
      }
    }
  }
  bool was_up = atomic_exchange(&l->connected, false);
  vc_sendq_clear(l->q);
  vc_decoder_free(dec);
  sodium_memzero(&l->tx, sizeof l->tx);
  if (atomic_load(&l->running))
    vc_log(VC_LOG_WARN, "link: disconnected from %s:%u: %s", l->host, l->cfg.port, why);
  if (was_up && l->cb.on_connection) l->cb.on_connection(l->cb.user, false);
  return authed;
}

static void* link_main(void* arg) {
  vc_link* l = arg;
  int backoff = l->cfg.reconnect_min_ms;
  bool warned = false;
  while (atomic_load(&l->running)) {
    int fd = connect_host(l);
    if (fd < 0) {
      if (!warned) vc_log(VC_LOG_WARN, "link: host %s:%u not reachable; retrying", l->host, l->cfg.port);
      warned = true;
      sleep_interruptible(l, backoff);
      backoff = backoff * 2 > l->cfg.reconnect_max_ms ? l->cfg.reconnect_max_ms : backoff * 2;
      continue;
    }
    warned = false;
    stat_add(l, &l->st.connects, 1);
    vc_log(VC_LOG_INFO, "link: connected to %s:%u", l->host, l->cfg.port);
    bool session = run_connection(l, fd);
    close(fd);
    stat_add(l, &l->st.disconnects, 1);
    /* A real session starts the backoff again; a peer that never proved the key makes it grow, so an
     * orphan does not hammer a stranger on its host's port. */
    if (session) backoff = l->cfg.reconnect_min_ms;
    if (atomic_load(&l->running)) sleep_interruptible(l, session ? l->cfg.reconnect_min_ms : backoff);
    if (!session) backoff = backoff * 2 > l->cfg.reconnect_max_ms ? l->cfg.reconnect_max_ms : backoff * 2;
  }
  return NULL;
}

int vc_link_new(const vc_link_config* cfg, const vc_link_callbacks* cb, const uint8_t* hello,
                size_t hello_len, vc_link** out, char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  if (out) *out = NULL;
  if (!out || !cfg || !cfg->host || !cfg->port || !hello || !hello_len) {
    vc_why(why, why_len, "link: %s",
           !out || !cfg               ? "invalid arguments"
           : !cfg->host || !cfg->port ? "no host address or port"
                                      : "no HELLO");
    return -EINVAL;
  }
  vc_link* l = calloc(1, sizeof(*l));
  if (!l) {
    vc_why(why, why_len, "link: out of memory");
    return -ENOMEM;
  }
  l->cfg = *cfg;
  snprintf(l->host, sizeof(l->host), "%s", cfg->host);
  l->cfg.host = l->host;
  if (!l->cfg.queue_msgs) l->cfg.queue_msgs = 64;
  if (!l->cfg.queue_bytes) l->cfg.queue_bytes = 32u << 20;
  if (!l->cfg.reconnect_min_ms) l->cfg.reconnect_min_ms = 100;
  if (!l->cfg.reconnect_max_ms) l->cfg.reconnect_max_ms = 5000;
  if (!l->cfg.heartbeat_ms) l->cfg.heartbeat_ms = 250;
  if (!l->cfg.host_timeout_ms) l->cfg.host_timeout_ms = 3000;
  if (cb) l->cb = *cb;
  l->cfg.key = NULL;
  if (cfg->key) {
    if (vc_auth_init() < 0) {
      vc_why(why, why_len, "link: libsodium failed to start");
      free(l);
      return -EIO;
    }
    memcpy(l->key, cfg->key, VC_AUTH_KEY_SIZE);
    l->keyed = true;
    if (cfg->next_key) {
      memcpy(l->next_key, cfg->next_key, VC_AUTH_KEY_SIZE);
      l->has_next = true;
    }
  }
  l->cfg.next_key = NULL;
  int rc = -ENOMEM;
  char qwhy[128] = "out of memory";
  l->hello = malloc(hello_len);
  if (!l->hello || (rc = vc_sendq_new(l->cfg.queue_msgs, l->cfg.queue_bytes, &l->q, qwhy, sizeof qwhy)) < 0) {
    if (!l->hello) rc = -ENOMEM;
    vc_why(why, why_len, "link: %s", qwhy);
    goto err;
  }
  memcpy(l->hello, hello, hello_len);
  l->hello_len = hello_len;
  l->wake_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (l->wake_fd < 0) {
    rc = -errno;
    vc_why(why, why_len, "link: eventfd: %s", strerror(-rc));
    goto err;
  }
  pthread_mutex_init(&l->mu, NULL);
  atomic_store(&l->running, true);
  if ((rc = -pthread_create(&l->thread, NULL, link_main, l)) != 0) {
    vc_why(why, why_len, "link: cannot start its thread: %s", strerror(-rc));
    goto err_fd;
  }
  *out = l;
  return 0;
err_fd:
  close(l->wake_fd);
  pthread_mutex_destroy(&l->mu);
err:
  vc_sendq_free(l->q);
  free(l->hello);
  free(l);
  return rc;
}

void vc_link_free(vc_link* l) {
  if (!l) return;
  atomic_store(&l->running, false);
  uint64_t one = 1;
  if (write(l->wake_fd, &one, sizeof(one)) < 0) { /* eventfd cannot overflow at 1 */
  }
  vc_sendq_wake(l->q);
  pthread_join(l->thread, NULL);
  close(l->wake_fd);
  vc_sendq_free(l->q);
  pthread_mutex_destroy(&l->mu);
  free(l->hello);
  free(l->seal);
  sodium_memzero(l->key, sizeof l->key);
  sodium_memzero(l->next_key, sizeof l->next_key);
  free(l);
}

int vc_link_send(vc_link* l, const uint8_t* msg, size_t len) {
  if (!atomic_load(&l->connected)) {
    stat_add(l, &l->st.queue_dropped, 1);
    return -ENOTCONN;
  }
  int rc = vc_sendq_push(l->q, msg, len);
  uint64_t one = 1;
  if (write(l->wake_fd, &one, sizeof(one)) < 0) { /* counter saturation is harmless */
  }
  return rc;
}

int vc_link_send_if_room(vc_link* l, const uint8_t* msg, size_t len) {
  if (!atomic_load(&l->connected)) return -ENOTCONN;
  int rc = vc_sendq_push_if_room(l->q, msg, len);
  uint64_t one = 1;
  if (rc == 0 && write(l->wake_fd, &one, sizeof(one)) < 0) { /* counter saturation is harmless */
  }
  return rc;
}

bool vc_link_connected(const vc_link* l) {
  return atomic_load(&l->connected);
}

void vc_link_get_stats(vc_link* l, vc_link_stats* s) {
  pthread_mutex_lock(&l->mu);
  *s = l->st;
  pthread_mutex_unlock(&l->mu);
  vc_sendq_stats q;
  vc_sendq_get_stats(l->q, &q);
  s->queue_pushed = q.pushed;
  s->queue_dropped += q.dropped;
  s->queue_sent = q.sent;
  s->connected = atomic_load(&l->connected);
}
