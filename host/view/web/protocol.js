// Decoder of the viewer's WebSocket messages (host/view/PROTOCOL.md). Every message: u8 type, u8 version,
// u16 flags, then the body, little-endian.
export const T = { Hello: 1, Hull: 2, Pose: 3, Features3D: 4, Features2D: 5, Silhouette: 6, Stats: 7, Replay: 8 };
const text = new TextDecoder();

// The RLE of proto/SPEC.md: LEB128 run lengths, alternating empty, occupied, ... from an empty run.
// Calls fn(start, length) for every occupied run; returns the bits covered.
export function rleRuns(bytes, fn) {
  let pos = 0, occupied = false, i = 0;
  while (i < bytes.length) {
    let v = 0, shift = 0, b;
    do { b = bytes[i++]; v += (b & 0x7f) * 2 ** shift; shift += 7; } while (b & 0x80 && i < bytes.length);
    if (occupied && v > 0) fn(pos, v);
    pos += v; occupied = !occupied;
  }
  return pos;
}

export function decode(buf) {
  const dv = new DataView(buf);
  const type = dv.getUint8(0);
  const u64 = (o) => Number(dv.getBigUint64(o, true));
  switch (type) {
    case T.Hello: case T.Stats: case T.Replay:
      return { type, json: JSON.parse(text.decode(new Uint8Array(buf, 4))) };
    case T.Hull: {
      const n = dv.getUint32(48, true);
      return { type, seq: u64(4), t_trigger_ns: u64(12), grid_id: dv.getUint32(20, true), flags: dv.getUint8(24),
               present: dv.getUint8(25), missing: dv.getUint8(26), voxels: u64(28), occupied: u64(36),
               latency_ms: dv.getFloat32(44, true), rle: new Uint8Array(buf, 52, n) };
    }
    case T.Pose: {
      const n = dv.getUint8(13), joints = [];
      for (let j = 0; j < n; j++) {
        const o = 24 + 12 * j;
        joints.push([dv.getFloat32(o, true), dv.getFloat32(o + 4, true), dv.getFloat32(o + 8, true)]);
      }
      return { type, seq: u64(4), state: dv.getUint8(12), confidence: dv.getFloat32(16, true),
               body_version: dv.getUint32(20, true), joints };
    }
    case T.Features3D: {
      const n = dv.getUint8(12), features = [];
      for (let k = 0; k < n; k++) {
        const o = 16 + 20 * k;
        features.push({ id: dv.getUint8(o), state: dv.getUint8(o + 1), views: dv.getUint8(o + 2),
                        confidence: dv.getFloat32(o + 4, true),
                        p: [dv.getFloat32(o + 8, true), dv.getFloat32(o + 12, true), dv.getFloat32(o + 16, true)] });
      }
      return { type, seq: u64(4), features };
    }
    case T.Features2D: {
      const n = dv.getUint8(12), cameras = [];
      let o = 16;
      for (let c = 0; c < n; c++) {
        const e = { node: dv.getUint16(o, true), camera: dv.getUint16(o + 2, true), rig_camera: dv.getUint16(o + 4, true), features: [] };
        const k = dv.getUint8(o + 6);
        o += 8;
        for (let i = 0; i < k; i++, o += 16)
          e.features.push({ id: dv.getUint8(o), state: dv.getUint8(o + 1), u: dv.getFloat32(o + 4, true),
                            v: dv.getFloat32(o + 8, true), confidence: dv.getFloat32(o + 12, true) });
        cameras.push(e);
      }
      return { type, seq: u64(4), cameras };
    }
    case T.Silhouette: {
      const n = dv.getUint32(24, true);
      return { type, seq: u64(4), node: dv.getUint16(12, true), camera: dv.getUint16(14, true),
               rig_camera: dv.getUint16(16, true), scale: dv.getUint16(18, true), width: dv.getUint16(20, true),
               height: dv.getUint16(22, true), rle: new Uint8Array(buf, 28, n) };
    }
  }
  return { type };
}
