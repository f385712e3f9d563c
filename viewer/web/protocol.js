// The frame server's wire format (docs/viewer.md, "Wire format";
// viewer/include/soda/viewer/frame_codec.h writes it).
const MAGIC = 'SVF1';
const HEADER_BYTES = 40;
const HAS_HASH = 1;
const FINISHED = 2;
const HAS_IDS = 4;

export async function fetchJson(path) {
  const res = await fetch(path, { cache: 'no-store' });
  if (!res.ok) throw new Error(`${path}: HTTP ${res.status}`);
  return res.json();
}

// The frame at `query` ('after=N' or 'at=N'); null when the server has none
// (204: nothing newer yet; 404: not held).
export async function fetchFrame(query) {
  const res = await fetch(`/frame?${query}`, { cache: 'no-store' });
  if (res.status === 204 || res.status === 404) return null;
  if (!res.ok) throw new Error(`/frame?${query}: HTTP ${res.status}`);
  return parseFrame(await res.arrayBuffer());
}

// Descriptions of bodies added during the run (the header lacks them):
// [{id, static, shape, position, orientation}] for those the server knows.
export async function fetchBodies(ids) {
  const res = await fetch(`/bodies?ids=${Array.from(ids).join(',')}`, { cache: 'no-store' });
  if (!res.ok) throw new Error(`/bodies: HTTP ${res.status}`);
  return (await res.json()).bodies;
}

// Typed-array views on one binary frame: {step, n, ids (Uint32Array n, or
// null: the header's dynamic bodies), position (Float32Array 3n),
// orientation (4n, x y z w), worldBusyMs, owner (Uint16Array n), cellOwner
// (Uint16Array c, empty: unchanged), sleeping (Uint8Array n), stateHash (16
// hex digits or null), finished}.
export function parseFrame(buffer) {
  const view = new DataView(buffer);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== MAGIC) throw new Error(`not a SODA frame (magic '${magic}')`);
  const flags = view.getUint32(4, true);
  const step = Number(view.getBigInt64(8, true));
  const n = view.getUint32(16, true);
  const b = view.getUint32(20, true);
  const c = view.getUint32(24, true);
  const hash = view.getBigUint64(32, true);
  let at = HEADER_BYTES;
  const take = (Type, count) => {
    const array = new Type(buffer, at, count);
    at += count * Type.BYTES_PER_ELEMENT;
    return array;
  };
  const frame = {
    step, n,
    ids: (flags & HAS_IDS) ? take(Uint32Array, n) : null,
    position: take(Float32Array, 3 * n),
    orientation: take(Float32Array, 4 * n),
    worldBusyMs: take(Float32Array, b),
    owner: take(Uint16Array, n),
    cellOwner: take(Uint16Array, c),
    sleeping: take(Uint8Array, n),
    stateHash: (flags & HAS_HASH) ? hash.toString(16).padStart(16, '0') : null,
    finished: (flags & FINISHED) !== 0,
  };
  if (at !== buffer.byteLength) throw new Error(`frame ${step}: ${buffer.byteLength} bytes, expected ${at}`);
  return frame;
}
