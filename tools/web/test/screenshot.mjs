// The screenshot of docs/web.md: the viewer at 32x on a point of the image.
//
//   node screenshot.mjs CHROMIUM URL CX CY OUT.png
//
// Prints the view drawn (its region and size) as JSON.
import { mkdtempSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium } from "playwright-core";

const [exe, url, cx, cy, out] = process.argv.slice(2);
const context = await chromium.launchPersistentContext(mkdtempSync(join(tmpdir(), "caoen-shot-")), {
  executablePath: exe,
  headless: true,
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync"],
  viewport: { width: 800, height: 600 },
  deviceScaleFactor: 1,
});
try {
  const page = context.pages()[0] ?? (await context.newPage());
  const ready = () => page.waitForFunction(() => document.body.dataset.state === "ready", null, { timeout: 120000 });
  await page.goto(url);
  await ready();
  await page.evaluate(([x, y]) => window.caoenLook(x, y, 32), [Number(cx), Number(cy)]);
  await ready();
  await page.screenshot({ path: out });
  console.log(JSON.stringify(await page.evaluate(() => window.caoenView)));
} finally {
  await context.close();
}
