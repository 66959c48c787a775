/* libFuzzer target: the rig key file (auth.h, vc_key_load), a file a user may be handed and the host,
 * `voxcap config check`, `voxcap key check` and every edge read.
 *
 * The input is written to a private file with mode 0600 and loaded. Properties: nothing crashes or
 * reads past the file; the file is accepted exactly when it is one line of 64 hex digits (one final
 * newline allowed), and then the key is those digits; a refused file leaves a one-line reason. */
#define _POSIX_C_SOURCE 200809L /* open flags, getpid in C11 */
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "voxcap/auth.h"

static int hexval(uint8_t c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static char path[64];
  if (!path[0]) snprintf(path, sizeof path, "/tmp/voxcap-keyfile-fuzz-%ld", (long)getpid());
  int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) abort();
  if (size && write(fd, data, size) != (ssize_t)size) abort();
  close(fd);
  uint8_t key[VC_AUTH_KEY_SIZE];
  char why[512];
  memset(why, 'x', sizeof why);
  int rc = vc_key_load(path, key, why, sizeof why);
  unlink(path);
  size_t len = size;
  if (len && data[len - 1] == '\n') len--;
  int valid = len == 2 * VC_AUTH_KEY_SIZE;
  for (size_t i = 0; valid && i < len; i++) valid = hexval(data[i]) >= 0;
  if (valid != (rc == 0)) abort();
  if (rc == 0) {
    for (size_t i = 0; i < VC_AUTH_KEY_SIZE; i++)
      if (key[i] != (uint8_t)(hexval(data[2 * i]) << 4 | hexval(data[2 * i + 1]))) abort();
  } else {
    if (!memchr(why, '\0', sizeof why) || strchr(why, '\n') || why[0] == '\0') abort();
  }
  return 0;
}
