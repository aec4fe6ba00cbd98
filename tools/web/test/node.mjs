// Checks the WebAssembly decoder in Node against the command line's decodes.
//
//   node node.mjs CASES.json
//
// CASES.json: {"pkg": DIR, "cases": [{"cae", "call": "decode"|"decodeRegion"|"info",
// "args": [...], "expect": RAW-RGBA-FILE | null, "width", "height", "tolerance",
// "info": {...} | null, "error": TEXT | null}]}. Prints one JSON line per case
// ({"name", "ok", "why", "ms"}) and exits 1 if any failed.
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { pathToFileURL } from "node:url";

const spec = JSON.parse(readFileSync(process.argv[2], "utf8"));
const caoen = await import(pathToFileURL(join(spec.pkg, "caoen.js")).href);
caoen.initSync({ module: readFileSync(join(spec.pkg, "caoen_bg.wasm")) });

function check(c) {
  const bytes = new Uint8Array(readFileSync(c.cae));
  if (c.error !== null) {
    try {
      caoen[c.call](bytes, ...c.args);
    } catch (e) {
      if (!(e instanceof Error)) return `threw ${typeof e}, not an Error`;
      if (!e.message.includes(c.error)) return `message ${JSON.stringify(e.message)} lacks ${JSON.stringify(c.error)}`;
      return null;
    }
    return "no error thrown";
  }
  const out = caoen[c.call](bytes, ...c.args);
  if (c.info !== null) {
    for (const [k, v] of Object.entries(c.info)) {
      if (out[k] !== v) return `${k} = ${out[k]}, expected ${v}`;
    }
    if (typeof out.metadata !== "object") return "no metadata object";
    return null;
  }
  if (out.width !== c.width || out.height !== c.height) {
    return `size ${out.width}x${out.height}, expected ${c.width}x${c.height}`;
  }
  if (!(out.data instanceof Uint8ClampedArray)) return "data is not a Uint8ClampedArray";
  const want = readFileSync(c.expect);
  if (want.length !== out.data.length) return `${out.data.length} samples, expected ${want.length}`;
  let worst = 0;
  for (let i = 0; i < want.length; i++) worst = Math.max(worst, Math.abs(want[i] - out.data[i]));
  return worst > c.tolerance ? `a sample differs by ${worst} (tolerance ${c.tolerance})` : null;
}

let failed = 0;
for (const c of spec.cases) {
  const t = performance.now();
  let why;
  try {
    why = check(c);
  } catch (e) {
    why = `threw: ${e && e.message}`;
  }
  if (why !== null) failed++;
  console.log(JSON.stringify({ name: c.name, ok: why === null, why, ms: performance.now() - t }));
}
process.exit(failed ? 1 : 0);
