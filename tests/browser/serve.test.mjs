// The browser test of `isoview serve` (docs/serve.md): Debian's chromium, headless,
// driven by playwright-core. Moves the isovalue slider and checks that the image changes;
// clicks a pixel and checks that the probe panel shows its cells; saves the page as
// a screenshot (docs/serve.png in docs/serve.md: SCREENSHOT=docs/serve.png tests/browser/run).
//
//   ISOVIEW_BIN=target/debug/isoview node tests/browser/serve.test.mjs
//   (defaults: CHROMIUM=/usr/bin/chromium, SCREENSHOT=target/browser/serve.png; tests/browser/run
//   installs what is missing and sets these)
import { spawn } from 'node:child_process';
import { createInterface } from 'node:readline';
import { strict as assert } from 'node:assert';
import { fileURLToPath } from 'node:url';
import path from 'node:path';
import { mkdirSync } from 'node:fs';
import { chromium } from 'playwright-core';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const bin = path.resolve(root, process.env.ISOVIEW_BIN || 'target/debug/isoview');
const screenshot = path.resolve(root, process.env.SCREENSHOT || 'target/browser/serve.png');

const server = spawn(bin, ['serve', 'scenes/cell-tunnel.toml', '--port', '0', '--set', 'image.width=384', '--set', 'image.height=384'], {
  cwd: root,
  stdio: ['ignore', 'pipe', 'inherit'],
});
const url = await new Promise((resolve, reject) => {
  const timer = setTimeout(() => reject(new Error('isoview serve printed no URL in 120 s')), 120000);
  server.on('exit', (code) => reject(new Error(`isoview serve exited with ${code}`)));
  createInterface({ input: server.stdout }).once('line', (line) => { clearTimeout(timer); resolve(line.trim()); });
});
assert.match(url, /^http:\/\/127\.0\.0\.1:\d+\/\?token=[0-9a-f]{32}$/);

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update',
    '--disable-sync', '--no-first-run'],
});
const errors = [];
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('response', (r) => { if (r.status() >= 400) errors.push(`${r.status()} ${r.url()}`); });
  page.on('console', (m) => { if (m.type() === 'error') errors.push(`${m.text()} (${m.location().url})`); });
  await page.goto(url);

  const fullFrame = async (after) => page.waitForFunction((g) => {
    const t = document.getElementById('timings').textContent;
    const m = t.match(/^full #(\d+)/);
    return m && Number(m[1]) > g ? Number(m[1]) : null;
  }, after, { timeout: 60000 }).then((h) => h.jsonValue());
  const pixels = () => page.evaluate(() => document.getElementById('image').toDataURL());

  const first = await fullFrame(0);
  const before = await pixels();

  // Move the isovalue slider with the keyboard: 30 presses, coalesced by the server.
  await page.focus('#isovalue');
  const iso0 = Number(await page.inputValue('#isovalue'));
  for (let i = 0; i < 30; i++) await page.keyboard.press('ArrowRight');
  const iso1 = Number(await page.inputValue('#isovalue'));
  assert.ok(iso1 > iso0, `slider moved: ${iso0} -> ${iso1}`);
  const second = await fullFrame(first);
  await page.waitForFunction((v) => document.getElementById('command').textContent.includes('surface.isovalue=' + v),
    String(Number(iso1.toPrecision(6))), { timeout: 10000 }).catch(() => {});
  // Wait for the frame of the last key press.
  await page.waitForFunction(() => !document.getElementById('timings').textContent.startsWith('coarse'));
  const after = await pixels();
  assert.notEqual(after, before, 'the image changed with the isovalue');
  const stats = await page.evaluate(async () => (await fetch('/api/stats', { headers: { 'X-Isoview-Token': new URLSearchParams(location.search).get('token') } })).json());
  console.log(`30 key presses: frames ${JSON.stringify(stats)}, now full #${second}+`);

  // Click a pixel on the surface, left of the tunnel: its ray crosses the scene's one cell.
  const box = await page.locator('#image').boundingBox();
  await page.mouse.click(box.x + box.width * 0.25 + 1, box.y + box.height / 2 + 1);
  await page.waitForFunction(() => document.getElementById('probe').textContent.includes('cell'), null, { timeout: 30000 });
  const probe = await page.textContent('#probe');
  assert.match(probe, /pixel \(96, 192\) of 384x384/);
  assert.match(probe, /\[0, 0, 0\]/, 'the probe lists cell [0, 0, 0] with its corners');
  assert.match(probe, /-1, 0\.3, 0\.25, 0\.35, 0\.3, 0\.25, 0\.2, -0\.9/, 'corner values shown');
  assert.match(probe, /fixed-step/);

  // Hover reads the full frame's channels (from /api/aov) under the cursor.
  const hx = box.x + box.width * 0.25 + 1, hy = box.y + box.height / 2 + 1;
  let hover = '';
  for (let i = 0; i < 50 && !/Z [0-9.]+ {2}N \(/.test(hover); i++) {
    await page.mouse.move(hx + (i % 2), hy);
    hover = await page.textContent('#hover');
    await page.waitForTimeout(100);
  }
  assert.match(hover, /steps \d+ {2}cell \[0, 0, 0\]/, `hover: ${hover}`);

  // The slice panel, for the screenshot.
  await page.check('#slice-on');
  await page.waitForFunction(() => {
    const img = document.getElementById('slice-img');
    return img.complete && img.naturalWidth > 0 && document.getElementById('slice-info').textContent.includes('layers');
  }, null, { timeout: 30000 });
  mkdirSync(path.dirname(screenshot), { recursive: true });
  await page.screenshot({ path: screenshot, fullPage: true });
  assert.deepEqual(errors, [], 'no errors on the page');
  console.log(`browser test passed; screenshot ${path.relative(root, screenshot)}`);
} finally {
  await browser.close();
  server.kill();
}
