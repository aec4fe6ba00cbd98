// Drives the viewer in headless Chromium (Debian's chromium, through playwright-core)
// and records what it drew, for tests/web_browser.rs to compare with native decodes.
//
//   node browser.mjs SPEC.json
//
// SPEC.json: {"chromium", "profile" (a fresh user-data-dir), "url" (the viewer with
// ?src= of a good file), "bad_url" (of a damaged one), "out" (a folder),
// "screenshot" (a PNG path, or null)}. Writes OUT/steps.json: per step its view
// (region, size, placement, zoom) and the canvas's pixels there as OUT/<step>.rgba;
// the error step's state and message; the page's decode time of the whole image.
import { writeFileSync } from "node:fs";
import { join } from "node:path";
import { chromium } from "playwright-core";

const spec = JSON.parse((await import("node:fs")).readFileSync(process.argv[2], "utf8"));
const context = await chromium.launchPersistentContext(spec.profile, {
  executablePath: spec.chromium,
  headless: true,
  args: [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
  ],
  viewport: { width: 800, height: 600 },
  deviceScaleFactor: 1,
});
const result = { steps: [] };
try {
  const page = context.pages()[0] ?? (await context.newPage());
  const logs = [];
  page.on("console", (m) => logs.push(m.text()));
  page.on("pageerror", (e) => logs.push(`page error: ${e.message}`));
  result.logs = logs;

  const settled = async () => {
    await page.waitForFunction(
      () => ["ready", "error"].includes(document.body.dataset.state), null, { timeout: 120000 });
    return page.evaluate(() => document.body.dataset.state);
  };
  const record = async (name) => {
    const state = await settled();
    const got = await page.evaluate(() => {
      const v = window.caoenView;
      const c = document.getElementById("view");
      const d = c.getContext("2d").getImageData(v.dx, v.dy, v.width, v.height).data;
      let bin = "";
      for (let i = 0; i < d.length; i += 0x8000) bin += String.fromCharCode(...d.subarray(i, i + 0x8000));
      return { view: v, pixels: btoa(bin) };
    });
    const file = join(spec.out, `${name}.rgba`);
    writeFileSync(file, Buffer.from(got.pixels, "base64"));
    result.steps.push({ name, state, view: got.view, rgba: file });
  };
  // A wheel turn that multiplies the zoom by `factor` about (x, y).
  const wheelBy = async (factor, x, y) => {
    await page.mouse.move(x, y);
    await page.mouse.wheel(0, -Math.log(factor) / 0.002);
  };

  await page.goto(spec.url);
  await record("fit");
  let zoom = (await page.evaluate(() => window.caoenView.zoom));
  await wheelBy(4 / zoom, 330, 260);
  await record("zoom4");
  await wheelBy(8, 420, 300);
  await record("zoom32");
  if (spec.screenshot) await page.screenshot({ path: spec.screenshot });
  // A drag pans.
  await page.mouse.move(400, 300);
  await page.mouse.down();
  await page.mouse.move(300, 250, { steps: 4 });
  await page.mouse.up();
  await record("panned");
  const times = [];
  for (let i = 0; i < 3; i++) times.push(await page.evaluate(() => window.caoenBench()));
  result.bench_ms = times.sort((a, b) => a - b)[1];
  result.info = await page.evaluate(() => document.getElementById("details").textContent);

  await page.goto(spec.bad_url);
  result.bad_state = await settled();
  result.bad_message = await page.evaluate(() => document.getElementById("message").textContent);
} finally {
  writeFileSync(join(spec.out, "steps.json"), JSON.stringify(result, null, 1));
  await context.close();
}
