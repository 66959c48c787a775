/* vc_link: the edge's connection to the host.
 *
 * A thread that connects to the host over TCP, sends the node's HELLO first on every connection,
 * decodes the host's messages (any chunking) and hands each to a callback, and writes the outgoing
 * queue (vc_sendq: bounded, drop-oldest, so a slow link never blocks capture or grows memory). It
 * sends a HEARTBEAT every heartbeat_ms and drops the connection when the host has said nothing for
 * host_timeout_ms, after a decoding error (the reason is logged and, when the framing is still intact,
 * sent as ERROR), or when the host closes. It then reconnects with exponential backoff (min..max ms);
 * messages queued for a lost connection are dropped and counted (stale frames are worthless).
 *
 * With the rig key (cfg.key, protocol 2.3) the link sends its AUTH challenge after HELLO and obeys the
 * host only once the host has proved the key (AUTH response over both nonces); it then proves the key
 * itself and seals every message it sends and checks the MAC of every message it receives. A peer that
 * answers anything else (an orphan's host gone and a stranger listening on its port) is never obeyed:
 * the reason is logged, the connection dropped, and the link retries with growing backoff.
 */
#ifndef VOXCAP_EDGE_LINK_H
#define VOXCAP_EDGE_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/proto.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vc_link vc_link;

typedef struct vc_link_config {
  const char* host; /* IPv4/IPv6 address or name (copied) */
  uint16_t port;
  uint16_t node_id;
  unsigned queue_msgs;  /* 0 = 64 */
  size_t queue_bytes;   /* 0 = 32 MiB */
  int reconnect_min_ms; /* 0 = 100 */
  int reconnect_max_ms; /* 0 = 5000 */
  int heartbeat_ms;     /* 0 = 250 */
  int host_timeout_ms;  /* 0 = 3000 */
  const uint8_t* key;   /* the rig key, VC_AUTH_KEY_SIZE bytes (copied), or NULL: keyless (loopback) */
  /* With key: the rig's next key during a rotation (copied), or NULL. The host may prove either; the
   * link proves and keys the connection with the one the host proved (host/deploy/README.md "Keys"). */
  const uint8_t* next_key;
} vc_link_config;

typedef struct vc_link_callbacks {
  /* A message from the host (called on the link thread; views valid during the call only). */
  void (*on_message)(void* user, const vc_msg* msg);
  /* The connection came up (HELLO sent) or went down. */
  void (*on_connection)(void* user, bool up);
  /* The node state for HEARTBEAT (vc_node_state); called on the link thread. */
  uint32_t (*state)(void* user);
  void* user;
} vc_link_callbacks;

typedef struct vc_link_stats {
  uint64_t connects; /* successful connections */
  uint64_t disconnects;
  uint64_t bytes_sent, bytes_received;
  uint64_t messages_received;
  uint64_t rejected;      /* host messages the decoder rejected */
  uint64_t auth_failures; /* connections whose peer did not prove the key (2.3) */
  uint64_t mac_rejected;  /* host messages dropped by their MAC: forged, replayed, reordered (2.3) */
  uint64_t queue_pushed, queue_dropped, queue_sent;
  bool connected;
} vc_link_stats;

/* Starts the link thread; *out owns the link (vc_link_free). hello[0..hello_len) is copied and sent
 * first on every connection. 0, or a negative code with *out = NULL and a one-line reason in why (if
 * given). The link logs through vc_log (log.h). */
int vc_link_new(const vc_link_config* cfg, const vc_link_callbacks* cb, const uint8_t* hello,
                size_t hello_len, vc_link** out, char* why, size_t why_len);
/* Stops the thread, closes the connection, frees everything. NULL is a no-op. */
void vc_link_free(vc_link* link);

/* Queues a message for the host (copied). Never blocks on the network. 0, -EMSGSIZE or -ENOMEM;
 * while disconnected the message is dropped and counted (returns -ENOTCONN). */
int vc_link_send(vc_link* link, const uint8_t* msg, size_t len);
/* Queues a message only when the queue stays at most half full (vc_sendq_push_if_room): never drops
 * another message for it. 0, -ENOBUFS (no room), -ENOTCONN or -ENOMEM; nothing is counted as a queue
 * drop (the caller counts what it could not send). */
int vc_link_send_if_room(vc_link* link, const uint8_t* msg, size_t len);
bool vc_link_connected(const vc_link* link);
void vc_link_get_stats(vc_link* link, vc_link_stats* stats);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_EDGE_LINK_H */
