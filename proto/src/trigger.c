/* The emulated trigger datagram (SPEC.md "Trigger datagram"): the UDP stand-in for the trigger
 * pulse wire in the one-machine rig. Fixed 24 bytes; nothing to negotiate. */
#include <errno.h>

#include "voxcap/proto.h"
#include "wire.h"

int vc_trigger_dgram_encode(uint8_t out[VC_TRIGGER_DGRAM_SIZE], uint64_t seq, uint64_t t_ns) {
  if (!out) return -EINVAL;
  vc_st32(out + 0, VC_TRIGGER_DGRAM_MAGIC);
  vc_st16(out + 4, VC_TRIGGER_DGRAM_VERSION);
  vc_st16(out + 6, 0);
  vc_st64(out + 8, seq);
  vc_st64(out + 16, t_ns);
  return 0;
}

int vc_trigger_dgram_decode(const uint8_t* buf, size_t len, uint64_t* seq, uint64_t* t_ns) {
  if (!buf) return -EINVAL;
  if (len != VC_TRIGGER_DGRAM_SIZE) return -EBADMSG;
  if (vc_ld32(buf) != VC_TRIGGER_DGRAM_MAGIC) return -EBADMSG;
  if (vc_ld16(buf + 4) != VC_TRIGGER_DGRAM_VERSION) return -EBADMSG;
  if (seq) *seq = vc_ld64(buf + 8);
  if (t_ns) *t_ns = vc_ld64(buf + 16);
  return 0;
}
