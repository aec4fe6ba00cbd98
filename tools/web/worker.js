// The viewer's decoder thread: holds the open file and answers one request at a time,
// so a slow decode never blocks the page.
import init, { info, decodeRegion } from "./pkg/caoen.js";

const ready = init();
let bytes = null;

self.onmessage = async (e) => {
  const m = e.data;
  try {
    await ready;
    if (m.type === "open") {
      bytes = new Uint8Array(m.buffer);
      self.postMessage({ id: m.id, info: info(bytes) });
    } else if (m.type === "region") {
      const t = performance.now();
      const [x0, y0, x1, y1] = m.region;
      const out = decodeRegion(bytes, x0, y0, x1, y1, m.width, m.height);
      const ms = performance.now() - t;
      self.postMessage(
        { id: m.id, width: out.width, height: out.height, data: out.data, ms },
        [out.data.buffer],
      );
    } else if (m.type === "bench") {
      // The whole image at its size, as `caoen decode` makes it, timed.
      const i = info(bytes);
      const t = performance.now();
      decodeRegion(bytes, 0, 0, i.width, i.height, i.width, i.height);
      self.postMessage({ id: m.id, ms: performance.now() - t });
    }
  } catch (err) {
    self.postMessage({ id: m.id, error: String(err && err.message ? err.message : err) });
  }
};
