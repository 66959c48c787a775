/* Authenticated control (auth.h, SPEC.md "Authentication"): the key file, the proofs of the
 * challenge-response, the per-direction MAC trailer and the authenticated trigger datagram.
 *
 * Every MAC and proof is keyed BLAKE2b (libsodium's crypto_generichash), streamed through a state on
 * the stack, so nothing is allocated and a HULL's payload is hashed once where it lies. The counter is
 * part of what the tag covers: a receiver that expects counter c rejects a valid tag on c' < c as a
 * replay and on c' > c as reordering (over TCP a legitimate peer never produces either). */
#define _GNU_SOURCE
#include "voxcap/auth.h"

#include <errno.h>
#include <fcntl.h>
#include <sodium.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "internal.h"
#include "voxcap/crc32c.h"
#include "voxcap/why.h"
#include "wire.h"

static const char kProofLabel[] = "VXCP-proof-v1";
static const char kSessionLabel[] = "VXCP-session-v1";

int vc_auth_init(void) {
  return sodium_init() < 0 ? -EIO : 0;
}

void vc_auth_random(void* buf, size_t n) {
  randombytes_buf(buf, n);
}

/* ---- Key file ---------------------------------------------------------------------------------------- */

static int hexval(int c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

int vc_key_load(const char* path, uint8_t key[VC_AUTH_KEY_SIZE], char* why, size_t why_len) {
  vc_why_clear(why, why_len);
  if (!path || !key) return -EINVAL;
  char text[VC_AUTH_KEY_FILE_MAX + 1];
  int rc;
  int fd = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) {
    rc = -errno;
    vc_why(why, why_len, "key file %s: %s", path, strerror(-rc));
    return rc;
  }
  struct stat st;
  if (fstat(fd, &st) < 0) {
    rc = -errno;
    vc_why(why, why_len, "key file %s: %s", path, strerror(-rc));
    goto out;
  }
  if (!S_ISREG(st.st_mode)) {
    rc = -EINVAL;
    vc_why(why, why_len, "key file %s: not a regular file", path);
    goto out;
  }
  if (st.st_mode & (S_IRWXG | S_IRWXO)) {
    rc = -EACCES;
    vc_why(why, why_len, "key file %s: mode %03o lets group or others at it; run chmod 600 %s", path,
           (unsigned)(st.st_mode & 0777), path);
    goto out;
  }
  if (st.st_size > VC_AUTH_KEY_FILE_MAX) {
    rc = -EINVAL;
    vc_why(why, why_len, "key file %s: %lld bytes, a key file is one line of 64 hex digits", path,
           (long long)st.st_size);
    goto out;
  }
  size_t n = 0;
  for (;;) {
    ssize_t r = read(fd, text + n, sizeof(text) - 1 - n);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      rc = -errno;
      vc_why(why, why_len, "key file %s: %s", path, strerror(-rc));
      goto out;
    }
    if (r == 0 || (n += (size_t)r) == sizeof(text) - 1) break;
  }
  size_t len = n;
  if (len && text[len - 1] == '\n') len--;
  rc = -EINVAL;
  if (len != 2 * VC_AUTH_KEY_SIZE) {
    vc_why(why, why_len, "key file %s: not one line of 64 hex digits", path);
    goto out;
  }
  for (size_t i = 0; i < VC_AUTH_KEY_SIZE; i++) {
    int hi = hexval((unsigned char)text[2 * i]), lo = hexval((unsigned char)text[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      sodium_memzero(key, VC_AUTH_KEY_SIZE);
      vc_why(why, why_len, "key file %s: not one line of 64 hex digits", path);
      goto out;
    }
    key[i] = (uint8_t)(hi << 4 | lo);
  }
  rc = 0;
out:
  sodium_memzero(text, sizeof text);
  close(fd);
  return rc;
}

int vc_key_write(const char* path, bool overwrite, uint8_t key_out[VC_AUTH_KEY_SIZE], char* why,
                 size_t why_len) {
  vc_why_clear(why, why_len);
  if (!path) return -EINVAL;
  uint8_t key[VC_AUTH_KEY_SIZE];
  char text[2 * VC_AUTH_KEY_SIZE + 1];
  int flags = O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW | (overwrite ? O_TRUNC : O_EXCL);
  int rc = 0;
  int fd = open(path, flags, 0600);
  if (fd < 0) {
    rc = -errno;
    vc_why(why, why_len, "%s: %s%s", path, strerror(-rc),
           rc == -EEXIST ? " (use --force to replace it)" : "");
    return rc;
  }
  struct stat st;
  if (fstat(fd, &st) < 0 || !S_ISREG(st.st_mode) || fchmod(fd, 0600) < 0) {
    rc = errno ? -errno : -EINVAL;
    vc_why(why, why_len, "%s: not a regular file that can be made 0600", path);
    goto out;
  }
  randombytes_buf(key, sizeof key);
  sodium_bin2hex(text, sizeof text, key, sizeof key);
  text[2 * VC_AUTH_KEY_SIZE] = '\n';
  for (size_t off = 0; off < sizeof text;) {
    ssize_t w = write(fd, text + off, sizeof text - off);
    if (w < 0 && errno == EINTR) continue;
    if (w < 0) {
      rc = -errno;
      vc_why(why, why_len, "%s: %s", path, strerror(-rc));
      goto out;
    }
    off += (size_t)w;
  }
  if (fsync(fd) < 0) {
    rc = -errno;
    vc_why(why, why_len, "%s: %s", path, strerror(-rc));
    goto out;
  }
  if (key_out) memcpy(key_out, key, sizeof key);
out:
  sodium_memzero(key, sizeof key);
  sodium_memzero(text, sizeof text);
  if (close(fd) < 0 && rc == 0) rc = -errno;
  return rc;
}

/* ---- Handshake ----------------------------------------------------------------------------------------- */

static void hash_ids(crypto_generichash_state* st, const char* label, size_t label_len, uint16_t role,
                     uint16_t node_id, const uint8_t* nonce_node, const uint8_t* nonce_host) {
  uint8_t ids[4];
  vc_st16(ids, role);
  vc_st16(ids + 2, node_id);
  crypto_generichash_update(st, (const uint8_t*)label, label_len);
  crypto_generichash_update(st, ids, sizeof ids);
  crypto_generichash_update(st, nonce_node, VC_AUTH_NONCE_SIZE);
  crypto_generichash_update(st, nonce_host, VC_AUTH_NONCE_SIZE);
}

void vc_auth_prove(uint8_t proof[VC_AUTH_PROOF_SIZE], const uint8_t key[VC_AUTH_KEY_SIZE], uint16_t role,
                   uint16_t node_id, const uint8_t nonce_node[VC_AUTH_NONCE_SIZE],
                   const uint8_t nonce_host[VC_AUTH_NONCE_SIZE]) {
  crypto_generichash_state st;
  crypto_generichash_init(&st, key, VC_AUTH_KEY_SIZE, VC_AUTH_PROOF_SIZE);
  hash_ids(&st, kProofLabel, sizeof kProofLabel - 1, role, node_id, nonce_node, nonce_host);
  crypto_generichash_final(&st, proof, VC_AUTH_PROOF_SIZE);
  sodium_memzero(&st, sizeof st);
}

bool vc_auth_verify(const uint8_t proof[VC_AUTH_PROOF_SIZE], const uint8_t key[VC_AUTH_KEY_SIZE],
                    uint16_t role, uint16_t node_id, const uint8_t nonce_node[VC_AUTH_NONCE_SIZE],
                    const uint8_t nonce_host[VC_AUTH_NONCE_SIZE]) {
  uint8_t want[VC_AUTH_PROOF_SIZE];
  vc_auth_prove(want, key, role, node_id, nonce_node, nonce_host);
  bool ok = sodium_memcmp(want, proof, VC_AUTH_PROOF_SIZE) == 0;
  sodium_memzero(want, sizeof want);
  return ok;
}

void vc_auth_session(const uint8_t key[VC_AUTH_KEY_SIZE], uint16_t node_id,
                     const uint8_t nonce_node[VC_AUTH_NONCE_SIZE],
                     const uint8_t nonce_host[VC_AUTH_NONCE_SIZE], vc_mac* node_to_host,
                     vc_mac* host_to_node) {
  uint8_t session[crypto_kdf_KEYBYTES];
  crypto_generichash_state st;
  crypto_generichash_init(&st, key, VC_AUTH_KEY_SIZE, sizeof session);
  hash_ids(&st, kSessionLabel, sizeof kSessionLabel - 1, 0, node_id, nonce_node, nonce_host);
  crypto_generichash_final(&st, session, sizeof session);
  crypto_kdf_derive_from_key(node_to_host->key, VC_AUTH_KEY_SIZE, 1, "VXCPmac_", session);
  crypto_kdf_derive_from_key(host_to_node->key, VC_AUTH_KEY_SIZE, 2, "VXCPmac_", session);
  node_to_host->counter = host_to_node->counter = 0;
  sodium_memzero(session, sizeof session);
  sodium_memzero(&st, sizeof st);
}

/* ---- Per-message MAC --------------------------------------------------------------------------------------
 */

/* Tag over the counter, header bytes 0..31 (flags and payload_len as sent) and the body. */
static void mac_tag(const vc_mac* m, uint64_t counter, const uint8_t* hdr32, const uint8_t* body,
                    size_t body_len, uint8_t tag[VC_AUTH_TAG_SIZE]) {
  uint8_t c[8];
  vc_st64(c, counter);
  crypto_generichash_state st;
  crypto_generichash_init(&st, m->key, VC_AUTH_KEY_SIZE, VC_AUTH_TAG_SIZE);
  crypto_generichash_update(&st, c, sizeof c);
  crypto_generichash_update(&st, hdr32, 32);
  crypto_generichash_update(&st, body, body_len);
  crypto_generichash_final(&st, tag, VC_AUTH_TAG_SIZE);
}

int vc_mac_seal(vc_mac* tx, uint8_t* buf, size_t len, size_t cap, size_t* out_len) {
  if (!tx || !buf || !out_len || len < VC_PROTO_HEADER_SIZE) return -EINVAL;
  size_t plen = vc_ld32(buf + 12);
  if (plen != len - VC_PROTO_HEADER_SIZE || plen + VC_AUTH_TRAILER_SIZE > VC_PROTO_MAX_PAYLOAD)
    return -EINVAL;
  *out_len = len + VC_AUTH_TRAILER_SIZE;
  if (cap < *out_len) return -ENOSPC;
  uint32_t payload_crc = vc_ld32(buf + 32);
  vc_st16(buf + 8, (uint16_t)(vc_ld16(buf + 8) | VC_FLAG_MAC));
  vc_st32(buf + 12, (uint32_t)(plen + VC_AUTH_TRAILER_SIZE));
  uint8_t* trailer = buf + len;
  vc_st64(trailer, tx->counter);
  mac_tag(tx, tx->counter, buf, buf + VC_PROTO_HEADER_SIZE, plen, trailer + 8);
  tx->counter++;
  /* The CRC of the old payload continues over the trailer: no second pass over a HULL. */
  vc_st32(buf + 32, vc_crc32c(plen ? payload_crc : 0, trailer, VC_AUTH_TRAILER_SIZE));
  vc_st32(buf + 36, vc_crc32c(0, buf, 36));
  return 0;
}

int vc_mac_open(vc_mac* rx, const uint8_t* frame, size_t frame_len, vc_proto_diag* diag) {
  if (!rx || !frame || frame_len < VC_PROTO_HEADER_SIZE) return -EINVAL;
  uint16_t type = vc_ld16(frame + 6);
  const char* name = vc_msg_type_name(type) ? vc_msg_type_name(type) : "unknown-type";
  if (!(vc_ld16(frame + 8) & VC_FLAG_MAC) || frame_len < VC_PROTO_HEADER_SIZE + VC_AUTH_TRAILER_SIZE)
    return vc_diag_set(diag, VC_PROTO_EMAC, "%s without a MAC on an authenticated connection", name);
  size_t body_len = frame_len - VC_PROTO_HEADER_SIZE - VC_AUTH_TRAILER_SIZE;
  const uint8_t* trailer = frame + VC_PROTO_HEADER_SIZE + body_len;
  uint64_t counter = vc_ld64(trailer);
  uint8_t tag[VC_AUTH_TAG_SIZE];
  mac_tag(rx, counter, frame, frame + VC_PROTO_HEADER_SIZE, body_len, tag);
  if (sodium_memcmp(tag, trailer + 8, VC_AUTH_TAG_SIZE) != 0)
    return vc_diag_set(diag, VC_PROTO_EMAC, "%s: MAC does not verify (counter %llu): forged", name,
                       (unsigned long long)counter);
  if (counter < rx->counter)
    return vc_diag_set(diag, VC_PROTO_EREPLAY, "%s: counter %llu was already used (next is %llu): replayed",
                       name, (unsigned long long)counter, (unsigned long long)rx->counter);
  if (counter > rx->counter)
    return vc_diag_set(diag, VC_PROTO_EORDER,
                       "%s: counter %llu but the next is %llu: reordered or one removed", name,
                       (unsigned long long)counter, (unsigned long long)rx->counter);
  rx->counter++;
  return 0;
}

/* ---- Trigger datagram
 * ---------------------------------------------------------------------------------------- */

void vc_auth_trigger_key(const uint8_t key[VC_AUTH_KEY_SIZE], vc_mac* out) {
  crypto_kdf_derive_from_key(out->key, VC_AUTH_KEY_SIZE, 3, "VXCPtrig", key);
  out->counter = 0;
}

static void dgram_tag(const vc_mac* m, const uint8_t* first32, uint8_t tag[VC_AUTH_TAG_SIZE]) {
  crypto_generichash(tag, VC_AUTH_TAG_SIZE, first32, 32, m->key, VC_AUTH_KEY_SIZE);
}

int vc_trigger_dgram_encode_mac(uint8_t out[VC_TRIGGER_DGRAM_MAC_SIZE], uint64_t seq, uint64_t t_ns,
                                vc_mac* tx) {
  if (!out || !tx) return -EINVAL;
  vc_trigger_dgram_encode(out, seq, t_ns);
  vc_st16(out + 4, VC_TRIGGER_DGRAM_MAC_VERSION);
  vc_st64(out + VC_TRIGGER_DGRAM_SIZE, tx->counter++);
  dgram_tag(tx, out, out + VC_TRIGGER_DGRAM_SIZE + 8);
  return 0;
}

int vc_trigger_dgram_decode_mac(const uint8_t* buf, size_t len, vc_mac* rx, uint64_t* seq, uint64_t* t_ns) {
  if (!buf || !rx) return -EINVAL;
  if (len != VC_TRIGGER_DGRAM_MAC_SIZE || vc_ld32(buf) != VC_TRIGGER_DGRAM_MAGIC ||
      vc_ld16(buf + 4) != VC_TRIGGER_DGRAM_MAC_VERSION)
    return -EBADMSG;
  uint8_t tag[VC_AUTH_TAG_SIZE];
  dgram_tag(rx, buf, tag);
  if (sodium_memcmp(tag, buf + VC_TRIGGER_DGRAM_SIZE + 8, VC_AUTH_TAG_SIZE) != 0) return VC_PROTO_EMAC;
  uint64_t counter = vc_ld64(buf + VC_TRIGGER_DGRAM_SIZE);
  if (counter < rx->counter) return VC_PROTO_EREPLAY;
  rx->counter = counter + 1;
  if (seq) *seq = vc_ld64(buf + 8);
  if (t_ns) *t_ns = vc_ld64(buf + 16);
  return 0;
}
