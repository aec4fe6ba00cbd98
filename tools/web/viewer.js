// The caoen viewer: a .cae file is a continuous image, so every view is decoded anew
// for exactly the pixels on screen (the visible region at the screen's resolution),
// in a worker, a quarter-resolution preview first. State for tests and embedders:
// document.body.dataset.state is "ready" after each finished draw, or "error"; the
// last draw's region and size are in window.caoenView.

const MAX_ZOOM = 64;
const canvas = document.getElementById("view");
const ctx = canvas.getContext("2d");
const $ = (id) => document.getElementById(id);
const worker = new Worker(new URL("./worker.js", import.meta.url), { type: "module" });

let info = null; // the open file's info()
let view = null; // { cx, cy, zoom }: image point at the centre, CSS pixels per image pixel
let last = null; // the last full draw: { canvas, left, top, s } for previews while moving
let requestId = 0;
const pending = new Map();
window.caoenTimings = [];

worker.onmessage = (e) => {
  const p = pending.get(e.data.id);
  pending.delete(e.data.id);
  if (!p) return;
  if (e.data.error !== undefined) p.reject(new Error(e.data.error));
  else p.resolve(e.data);
};
worker.onerror = (e) => fail(new Error(`worker: ${e.message || "failed to start"}`));

function call(message, transfer = []) {
  const id = ++requestId;
  return new Promise((resolve, reject) => {
    pending.set(id, { resolve, reject });
    worker.postMessage({ ...message, id }, transfer);
  });
}

function setState(s) {
  document.body.dataset.state = s;
}

function fail(err) {
  $("message").textContent = err.message;
  setState("error");
}

async function open(buffer) {
  setState("loading");
  $("message").textContent = "";
  try {
    const r = await call({ type: "open", buffer }, [buffer]);
    info = r.info;
    last = null;
    view = null;
    showDetails();
    fit();
  } catch (err) {
    info = null;
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    fail(err);
  }
}

function showDetails() {
  const m = info.metadata;
  const bpp = (info.bytes * 8) / (info.width * info.height);
  const meta = [
    m.icc && `ICC ${m.icc.length} B`,
    m.exif && `EXIF ${m.exif.length} B`,
    m.xmp && `XMP ${m.xmp.length} chars`,
  ].filter(Boolean);
  $("details").textContent =
    `${info.width}x${info.height}, ${info.channels} channels, ${info.bits}-bit, ` +
    `${info.bytes} bytes, ${bpp.toFixed(3)} bpp` +
    (meta.length ? `; ${meta.join(", ")}` : "; no metadata");
}

function size() {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth * dpr));
  const h = Math.max(1, Math.round(canvas.clientHeight * dpr));
  if (canvas.width !== w || canvas.height !== h) {
    canvas.width = w;
    canvas.height = h;
  }
  return dpr;
}

function fitZoom() {
  return Math.min(canvas.clientWidth / info.width, canvas.clientHeight / info.height);
}

function fit() {
  if (!info) return;
  view = { cx: info.width / 2, cy: info.height / 2, zoom: fitZoom() };
  redraw();
}

// Zoom by `factor` keeping the image point under CSS position (px, py) in place.
function zoomAt(factor, px, py) {
  if (!info) return;
  const lo = Math.min(fitZoom(), 1);
  const zoom = Math.min(MAX_ZOOM, Math.max(lo, view.zoom * factor));
  const ox = px - canvas.clientWidth / 2;
  const oy = py - canvas.clientHeight / 2;
  view.cx += ox / view.zoom - ox / zoom;
  view.cy += oy / view.zoom - oy / zoom;
  view.zoom = zoom;
  redraw();
}

function pan(dx, dy) {
  if (!info) return;
  view.cx -= dx / view.zoom;
  view.cy -= dy / view.zoom;
  redraw();
}

// The image's placement on the canvas (device pixels) and the visible part: whole
// device pixels, the region of the image they show, so that drawing the decode there
// needs no resampling.
function placement() {
  const dpr = size();
  const s = view.zoom * dpr;
  const left = canvas.width / 2 - view.cx * s;
  const top = canvas.height / 2 - view.cy * s;
  const px0 = Math.max(0, Math.ceil(left));
  const py0 = Math.max(0, Math.ceil(top));
  const px1 = Math.min(canvas.width, Math.floor(left + info.width * s));
  const py1 = Math.min(canvas.height, Math.floor(top + info.height * s));
  if (px1 <= px0 || py1 <= py0) return { s, left, top, empty: true };
  const region = [
    Math.max(0, (px0 - left) / s),
    Math.max(0, (py0 - top) / s),
    Math.min(info.width, (px1 - left) / s),
    Math.min(info.height, (py1 - top) / s),
  ];
  return { s, left, top, region, dx: px0, dy: py0, width: px1 - px0, height: py1 - py0 };
}

// The last full draw moved and scaled to the current view, while the new one decodes.
function drawMoved(p) {
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (!last) return;
  const k = p.s / last.s;
  ctx.imageSmoothingEnabled = true;
  ctx.drawImage(last.canvas, p.left - last.left * k, p.top - last.top * k,
    last.canvas.width * k, last.canvas.height * k);
}

function toCanvas(out) {
  const c = document.createElement("canvas");
  c.width = out.width;
  c.height = out.height;
  c.getContext("2d").putImageData(new ImageData(out.data, out.width, out.height), 0, 0);
  return c;
}

let busy = false;
let wanted = 0;
let drawn = 0;

function redraw() {
  $("zoom").textContent = `${view.zoom >= 10 ? view.zoom.toFixed(1) : view.zoom.toFixed(2)}x`;
  setState("loading");
  drawMoved(placement());
  wanted++;
  pump();
}

// Decodes the newest view when the worker is free: views asked for meanwhile are
// skipped, never queued.
async function pump() {
  if (busy || drawn === wanted || !info) return;
  busy = true;
  const generation = wanted;
  const p = placement();
  try {
    if (p.empty) {
      ctx.clearRect(0, 0, canvas.width, canvas.height);
      finish(generation, p, null);
    } else {
      const [x0, y0, x1, y1] = p.region;
      const pw = Math.max(1, Math.round(p.width / 4));
      const ph = Math.max(1, Math.round(p.height / 4));
      if (pw * ph * 16 >= 65536 && generation === wanted) {
        const preview = await call({ type: "region", region: p.region, width: pw, height: ph });
        if (generation === wanted) {
          drawMoved(p);
          ctx.imageSmoothingEnabled = true;
          ctx.drawImage(toCanvas(preview), p.dx, p.dy, p.width, p.height);
        }
      }
      if (generation === wanted) {
        const full = await call({ type: "region", region: [x0, y0, x1, y1], width: p.width, height: p.height });
        window.caoenTimings.push({ width: full.width, height: full.height, ms: full.ms });
        if (generation === wanted) finish(generation, p, full);
      }
    }
  } catch (err) {
    fail(err);
    drawn = generation;
  }
  busy = false;
  if (drawn !== wanted) pump();
}

function finish(generation, p, full) {
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  if (full) ctx.putImageData(new ImageData(full.data, full.width, full.height), p.dx, p.dy);
  const snapshot = document.createElement("canvas");
  snapshot.width = canvas.width;
  snapshot.height = canvas.height;
  snapshot.getContext("2d").drawImage(canvas, 0, 0);
  last = { canvas: snapshot, left: p.left, top: p.top, s: p.s };
  window.caoenView = full
    ? { region: p.region, width: p.width, height: p.height, dx: p.dx, dy: p.dy, zoom: view.zoom }
    : { region: null, zoom: view.zoom };
  drawn = generation;
  $("message").textContent = "";
  setState("ready");
}

// The whole image decoded at its size in the worker, in milliseconds.
window.caoenBench = async () => (await call({ type: "bench" })).ms;
// Shows image point (cx, cy) at the centre at `zoom` CSS pixels per image pixel.
window.caoenLook = (cx, cy, zoom) => {
  if (!info) return;
  view = { cx, cy, zoom: Math.min(MAX_ZOOM, Math.max(Math.min(fitZoom(), 1), zoom)) };
  redraw();
};

$("file").addEventListener("change", async (e) => {
  const f = e.target.files[0];
  if (f) open(await f.arrayBuffer());
});
$("zoom-in").onclick = () => info && zoomAt(2, canvas.clientWidth / 2, canvas.clientHeight / 2);
$("zoom-out").onclick = () => info && zoomAt(0.5, canvas.clientWidth / 2, canvas.clientHeight / 2);
$("zoom-fit").onclick = fit;

document.addEventListener("dragover", (e) => {
  e.preventDefault();
  document.body.classList.add("dragging");
});
document.addEventListener("dragleave", () => document.body.classList.remove("dragging"));
document.addEventListener("drop", async (e) => {
  e.preventDefault();
  document.body.classList.remove("dragging");
  const f = e.dataTransfer.files[0];
  if (f) open(await f.arrayBuffer());
});

canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  const r = canvas.getBoundingClientRect();
  const step = e.deltaMode === 1 ? 40 : e.deltaMode === 2 ? 800 : 1;
  zoomAt(Math.exp(-e.deltaY * step * 0.002), e.clientX - r.left, e.clientY - r.top);
}, { passive: false });

// Dragging pans; two pointers pinch.
const pointers = new Map();
canvas.addEventListener("pointerdown", (e) => {
  canvas.setPointerCapture(e.pointerId);
  pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
});
canvas.addEventListener("pointermove", (e) => {
  const was = pointers.get(e.pointerId);
  if (!was || !info) return;
  const now = { x: e.clientX, y: e.clientY };
  if (pointers.size === 2) {
    const other = [...pointers.entries()].find(([id]) => id !== e.pointerId)[1];
    const d0 = Math.hypot(was.x - other.x, was.y - other.y);
    const d1 = Math.hypot(now.x - other.x, now.y - other.y);
    const r = canvas.getBoundingClientRect();
    if (d0 > 0) zoomAt(d1 / d0, (now.x + other.x) / 2 - r.left, (now.y + other.y) / 2 - r.top);
  } else {
    pan(now.x - was.x, now.y - was.y);
  }
  pointers.set(e.pointerId, now);
});
const up = (e) => pointers.delete(e.pointerId);
canvas.addEventListener("pointerup", up);
canvas.addEventListener("pointercancel", up);

window.addEventListener("resize", () => info && redraw());

const src = new URLSearchParams(location.search).get("src");
if (src) {
  setState("loading");
  fetch(src)
    .then((r) => {
      if (!r.ok) throw new Error(`${src}: HTTP ${r.status}`);
      return r.arrayBuffer();
    })
    .then(open, fail);
}
