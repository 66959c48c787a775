/* Authenticated control (SPEC.md "Authentication", protocol 2.3): the rig key, the challenge-response
 * on connect, per-message MACs and the authenticated trigger datagram. libsodium does the
 * cryptography: keyed BLAKE2b (crypto_generichash) for proofs and MACs, crypto_kdf for the
 * per-connection, per-direction keys, randombytes_buf for nonces and keys, sodium_memcmp to compare.
 *
 * The rig key is 32 random bytes, stored as one line of 64 hex digits in a file only its owner may
 * read (mode 0600 or stricter). Host and node prove it to each other over both nonces, the node id and
 * their role, so neither a reflected nor a replayed proof passes; every later message carries a MAC
 * over a counter of its direction and the message, so a forged, replayed or reordered message is
 * rejected (VC_PROTO_EMAC, VC_PROTO_EREPLAY, VC_PROTO_EORDER) and the stream goes on.
 *
 * Nothing here allocates. vc_auth_init() must have returned 0 before any other function is used. */
#ifndef VOXCAP_AUTH_H
#define VOXCAP_AUTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "voxcap/proto.h"

#ifdef __cplusplus
extern "C" {
#endif

#define VC_AUTH_KEY_SIZE 32
#define VC_AUTH_NONCE_SIZE 32
#define VC_AUTH_PROOF_SIZE 32
#define VC_AUTH_TAG_SIZE 16                         /* BLAKE2b-128 */
#define VC_AUTH_TRAILER_SIZE (8 + VC_AUTH_TAG_SIZE) /* u64 counter, tag */
#define VC_AUTH_KEY_FILE_MAX 256                    /* bytes a key file may have */
#define VC_AUTH_MAX_REJECTS 16 /* MAC failures after which a receiver closes the connection */

/* Roles a proof is made for: a node's proof never passes as the host's (no reflection). */
enum vc_auth_role { VC_AUTH_ROLE_NODE = 1, VC_AUTH_ROLE_HOST = 2 };

/* Initialises libsodium (thread-safe, idempotent). 0, or -EIO when it cannot. */
int vc_auth_init(void);

/* Fills buf with n unpredictable bytes (randombytes_buf). */
void vc_auth_random(void* buf, size_t n);

/* ---- The key file ----------------------------------------------------------------------------------- */

/* Reads a key file: a regular file, not readable or writable by group or others, holding one line of
 * 64 hex digits (an optional final newline). 0, or a negative code with a one-line reason in why:
 * -EACCES (group/world permissions), -EINVAL (not one line of 64 hex digits), -EFTYPE-like -EINVAL for
 * a non-regular file, or -errno from open/read. */
int vc_key_load(const char* path, uint8_t key[VC_AUTH_KEY_SIZE], char* why, size_t why_len);

/* Writes 32 fresh random bytes as a key file with mode 0600. Refuses an existing file (-EEXIST)
 * unless overwrite; an existing file is then truncated and its mode set to 0600 before the key is
 * written. 0 or a negative code with a reason in why. key (may be NULL) receives the key. */
int vc_key_write(const char* path, bool overwrite, uint8_t key[VC_AUTH_KEY_SIZE], char* why, size_t why_len);

/* ---- Handshake ---------------------------------------------------------------------------------------- */

/* proof = BLAKE2b-256 keyed with the rig key over "VXCP-proof-v1" | role | node_id | nonce_node |
 * nonce_host (u16 little-endian). */
void vc_auth_prove(uint8_t proof[VC_AUTH_PROOF_SIZE], const uint8_t key[VC_AUTH_KEY_SIZE], uint16_t role,
                   uint16_t node_id, const uint8_t nonce_node[VC_AUTH_NONCE_SIZE],
                   const uint8_t nonce_host[VC_AUTH_NONCE_SIZE]);
/* True when proof is the one vc_auth_prove makes for these inputs (constant time). */
bool vc_auth_verify(const uint8_t proof[VC_AUTH_PROOF_SIZE], const uint8_t key[VC_AUTH_KEY_SIZE],
                    uint16_t role, uint16_t node_id, const uint8_t nonce_node[VC_AUTH_NONCE_SIZE],
                    const uint8_t nonce_host[VC_AUTH_NONCE_SIZE]);

/* A direction's MAC state: its key and the counter of the next message (sender: to write; receiver:
 * expected). */
typedef struct vc_mac {
  uint8_t key[VC_AUTH_KEY_SIZE];
  uint64_t counter;
} vc_mac;

/* The connection's two directions: session = BLAKE2b-256 keyed with the rig key over
 * "VXCP-session-v1" | node_id | nonce_node | nonce_host, then crypto_kdf_derive_from_key(session,
 * id 1 node->host, id 2 host->node, context "VXCPmac_"). Counters start at 0. */
void vc_auth_session(const uint8_t key[VC_AUTH_KEY_SIZE], uint16_t node_id,
                     const uint8_t nonce_node[VC_AUTH_NONCE_SIZE],
                     const uint8_t nonce_host[VC_AUTH_NONCE_SIZE], vc_mac* node_to_host,
                     vc_mac* host_to_node);

/* ---- Per-message MAC ---------------------------------------------------------------------------------- */

/* Seals the one whole message in buf[0..len) (as an encoder wrote it) in place: sets the header flag
 * VC_FLAG_MAC, appends the trailer (counter, tag over the counter, header bytes 0..31 and the
 * payload) and rewrites payload_len and both CRCs. *out_len = len + VC_AUTH_TRAILER_SIZE.
 * tx->counter is used and incremented. -EINVAL (not one whole message), -ENOSPC (cap too small). */
int vc_mac_seal(vc_mac* tx, uint8_t* buf, size_t len, size_t cap, size_t* out_len);

/* Checks the trailer of a message whose framing (CRCs) was already checked: frame = the whole message
 * as received. 0 (rx->counter advanced), VC_PROTO_EMAC (no MAC flag, no trailer or a wrong tag:
 * forged), VC_PROTO_EREPLAY (a valid tag on a counter below the expected one: replayed) or
 * VC_PROTO_EORDER (a valid tag on a counter above it: reordered or a message was removed). */
int vc_mac_open(vc_mac* rx, const uint8_t* frame, size_t frame_len, vc_proto_diag* diag);

/* ---- Authenticated trigger datagram (version 2) -------------------------------------------------------- */

#define VC_TRIGGER_DGRAM_MAC_VERSION 2
#define VC_TRIGGER_DGRAM_MAC_SIZE (VC_TRIGGER_DGRAM_SIZE + VC_AUTH_TRAILER_SIZE) /* 48 */

/* The trigger key: crypto_kdf_derive_from_key(rig key, id 3, context "VXCPtrig"). */
void vc_auth_trigger_key(const uint8_t key[VC_AUTH_KEY_SIZE], vc_mac* out);

/* A version-2 datagram: the 24 bytes of version 1 (version field 2), then tx->counter (u64) and the
 * tag over the first 32 bytes. tx->counter is incremented. */
int vc_trigger_dgram_encode_mac(uint8_t out[VC_TRIGGER_DGRAM_MAC_SIZE], uint64_t seq, uint64_t t_ns,
                                vc_mac* tx);
/* Accepts a version-2 datagram with a valid tag and a counter >= rx->counter (datagrams may be lost
 * but never taken twice or out of order), then sets rx->counter past it. 0, -EBADMSG (size, magic,
 * version), VC_PROTO_EMAC (tag), VC_PROTO_EREPLAY (counter below the expected). */
int vc_trigger_dgram_decode_mac(const uint8_t* buf, size_t len, vc_mac* rx, uint64_t* seq, uint64_t* t_ns);

#ifdef __cplusplus
}
#endif
#endif /* VOXCAP_AUTH_H */
