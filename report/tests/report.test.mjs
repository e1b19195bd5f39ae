// Browser tests of the report page in a real headless Chromium (Debian's), driven by playwright-core.
// Usage: AUTOSCAN_REPORT_HTML=/path/report.html node --test tests/
// (CTest runs this against a report of a synthetic session written by tests/report.)
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { chromium } from 'playwright-core';
import { pathToFileURL } from 'node:url';
import { existsSync } from 'node:fs';

const html = process.env.AUTOSCAN_REPORT_HTML;
const executablePath = process.env.CHROMIUM || '/usr/bin/chromium';
let browser, page;
const consoleErrors = [];

export const chromiumArgs = [
  '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update',
  '--disable-sync',
];

before(async () => {
  assert.ok(html && existsSync(html), `AUTOSCAN_REPORT_HTML must name an existing report (got ${html})`);
  browser = await chromium.launch({ executablePath, headless: true, args: chromiumArgs });
  page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  page.on('console', (msg) => { if (msg.type() === 'error') consoleErrors.push(msg.text()); });
  page.on('pageerror', (err) => consoleErrors.push(String(err)));
  await page.goto(pathToFileURL(html).href);
  await page.waitForFunction(() => window.autoscanReport && window.autoscanReport.ready, null, { timeout: 30000 });
});

after(async () => { await browser?.close(); });

// Share of canvas pixels that differ from the background colour.
async function nonBlankShare() {
  return page.evaluate(() => {
    window.autoscanReport.render();
    const src = document.querySelector('#viewport canvas');
    const c = document.createElement('canvas');
    c.width = src.width; c.height = src.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(src, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 0; i < d.length; i += 4) {
      if (Math.abs(d[i] - 244) + Math.abs(d[i + 1] - 244) + Math.abs(d[i + 2] - 244) > 30) ++n;
    }
    return n / (d.length / 4);
  });
}

test('page loads with no console errors', () => {
  assert.deepEqual(consoleErrors, []);
});

test('the 3D canvas has non-blank pixels', async () => {
  const share = await nonBlankShare();
  assert.ok(share > 0.01, `only ${(share * 100).toFixed(3)} % of the canvas differs from the background`);
});

test('the slider changes the iteration shown', async () => {
  const before0 = await page.evaluate(() => window.autoscanReport.state());
  assert.ok(before0.iterations >= 2, 'the fixture needs two iterations');
  const label1 = await page.textContent('#iteration-label');
  await page.evaluate(() => {
    const s = document.getElementById('iteration');
    s.value = '0';
    s.dispatchEvent(new Event('input'));
  });
  const after0 = await page.evaluate(() => window.autoscanReport.state());
  assert.equal(after0.iteration, 0);
  assert.notEqual(after0.points, before0.points);
  assert.notEqual(await page.textContent('#iteration-label'), label1);
  assert.ok((await nonBlankShare()) > 0.01);
});

test('the colour switch changes the mesh colours', async () => {
  const a = await page.evaluate(() => window.autoscanReport.state().meshColorChecksum);
  await page.selectOption('#color-by', 'f_g');
  const b = await page.evaluate(() => window.autoscanReport.state().meshColorChecksum);
  await page.selectOption('#color-by', 'f_s');
  const c = await page.evaluate(() => window.autoscanReport.state().meshColorChecksum);
  assert.notEqual(a, b);
  assert.notEqual(b, c);
  assert.deepEqual(consoleErrors, []);
});

// Shares of canvas pixels that are clearly red (r ≫ g, b) and clearly blue (b ≫ r, g).
async function redBlueShares() {
  return page.evaluate(() => {
    window.autoscanReport.render();
    const src = document.querySelector('#viewport canvas');
    const c = document.createElement('canvas');
    c.width = src.width; c.height = src.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(src, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let red = 0, blue = 0;
    for (let i = 0; i < d.length; i += 4) {
      const [r, g, b] = [d[i], d[i + 1], d[i + 2]];
      if (r > 80 && r > 2.5 * g && r > 2.5 * b) ++red;
      if (b > 80 && b > 2.5 * r && b > 1.8 * g) ++blue;
    }
    return { red: red / (d.length / 4), blue: blue / (d.length / 4) };
  });
}

test('the coloured model renders in its scanned colours and switches to confidence', async () => {
  // The fixture's last iteration has a coloured model (red above z = 0, blue below): the report
  // opens on it in its colours.
  const last = (await page.evaluate(() => window.autoscanReport.state())).iterations - 1;
  await page.evaluate((k) => window.autoscanReport.setIteration(k), last);
  await page.evaluate(() => window.autoscanReport.setColorBy('color'));
  assert.equal(await page.inputValue('#color-by'), 'color');
  await page.evaluate(() => {
    document.getElementById('show-cloud').checked = false;
    const o = document.getElementById('mesh-opacity');
    o.value = '1';  // opaque: the background does not wash the colours out
    o.dispatchEvent(new Event('input'));
  });
  const coloured = await redBlueShares();
  assert.ok(coloured.red > 0.02, `red share ${coloured.red}`);
  assert.ok(coloured.blue > 0.02, `blue share ${coloured.blue}`);
  const colourSum = await page.evaluate(() => window.autoscanReport.state().meshColorChecksum);
  // Confidence (f = 0.5 + z, the cool-warm map): other colours.
  await page.selectOption('#color-by', 'f');
  const confSum = await page.evaluate(() => window.autoscanReport.state().meshColorChecksum);
  assert.notEqual(colourSum, confSum);
  await page.selectOption('#color-by', 'color');
  assert.equal(await page.evaluate(() => window.autoscanReport.state().meshColorChecksum), colourSum);
  await page.evaluate(() => {
    document.getElementById('show-cloud').checked = true;
    const o = document.getElementById('mesh-opacity');
    o.value = '0.85';
    o.dispatchEvent(new Event('input'));
  });
  assert.deepEqual(consoleErrors, []);
});

test('plots are drawn', async () => {
  const n = await page.evaluate(() => document.querySelectorAll('#plots svg').length);
  assert.ok(n >= 2, `expected at least 2 plots, got ${n}`);
});
