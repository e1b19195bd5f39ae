// Browser tests of the report page in a real headless Chromium (Debian's), driven by playwright-core.
// Usage: AUTOSCAN_REPORT_HTML=/path/report.html node --test tests/
// (CTest runs this against a report of a synthetic session written by tests/report: two iterations of
// a sphere of radius 0.48 with f = 0.5 + z, two scans and two next views per iteration, a field slice
// at iteration 0 only, and at iteration 1 a certificate (threshold 0.45) with one region of each
// reason.) Set AUTOSCAN_REPORT_SHOTS=DIR to keep the screenshots the tests look at.
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { chromium } from 'playwright-core';
import { pathToFileURL } from 'node:url';
import { existsSync, mkdirSync } from 'node:fs';
import { join } from 'node:path';

const html = process.env.AUTOSCAN_REPORT_HTML;
const shots = process.env.AUTOSCAN_REPORT_SHOTS;
const executablePath = process.env.CHROMIUM || '/usr/bin/chromium';
let browser, page;
const consoleErrors = [];

export const chromiumArgs = [
  '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update',
  '--disable-sync',
];

// The marker colour of each certificate reason (report/src/colors.js).
const REASON_RGB = { not_scanned: [0x7c, 0x3a, 0xed], improving: [0xdb, 0x27, 0x77], unreachable: [0x11, 0x18, 0x27], too_noisy: [0xa1, 0x62, 0x07] };

async function openPage(width) {
  const p = await browser.newPage({ viewport: { width, height: 900 } });
  p.on('console', (msg) => { if (msg.type() === 'error') consoleErrors.push(msg.text()); });
  p.on('pageerror', (err) => consoleErrors.push(String(err)));
  await p.goto(pathToFileURL(html).href);
  await p.waitForFunction(() => window.autoscanReport && window.autoscanReport.ready, null, { timeout: 30000 });
  return p;
}

async function shot(p, name) {
  if (!shots) return;
  mkdirSync(shots, { recursive: true });
  await p.screenshot({ path: join(shots, name), fullPage: true });
}

before(async () => {
  assert.ok(html && existsSync(html), `AUTOSCAN_REPORT_HTML must name an existing report (got ${html})`);
  browser = await chromium.launch({ executablePath, headless: true, args: chromiumArgs });
  page = await openPage(1280);
  await installReadCanvas(page);
  await shot(page, 'report-1280.png');
});

after(async () => { await browser?.close(); });

// Installs window.readCanvas() in the page: the 3D canvas' pixels (ImageData, device pixels) after a
// render. The tests analyse them in the page: moving millions of numbers to node is slow.
async function installReadCanvas(p) {
  await p.evaluate(() => {
    window.readCanvas = () => {
      window.autoscanReport.render();
      const src = document.querySelector('#viewport canvas');
      const c = document.createElement('canvas');
      c.width = src.width; c.height = src.height;
      const ctx = c.getContext('2d');
      ctx.drawImage(src, 0, 0);
      return ctx.getImageData(0, 0, c.width, c.height);
    };
    window.isBackground = (d, i) => Math.abs(d[i] - 244) + Math.abs(d[i + 1] - 244) + Math.abs(d[i + 2] - 244) <= 30;
  });
}

// Share of canvas pixels that differ from the background colour.
async function nonBlankShare() {
  return page.evaluate(() => {
    const { data } = window.readCanvas();
    let n = 0;
    for (let i = 0; i < data.length; i += 4) if (!window.isBackground(data, i)) ++n;
    return n / (data.length / 4);
  });
}

async function setChecked(id, on) {
  await page.evaluate(([id, on]) => {
    const el = document.getElementById(id);
    el.checked = on;
    el.dispatchEvent(new Event('change'));
  }, [id, on]);
}

test('page loads with no console errors', () => {
  assert.deepEqual(consoleErrors, []);
});

test('the certificate heads the page: verdict, figures, one row per region', async () => {
  const r = await page.evaluate(() => {
    const top = (id) => document.getElementById(id).getBoundingClientRect().top;
    return {
      cert: top('certificate'), viewport: top('viewport'), verdict: document.getElementById('verdict').textContent,
      figures: document.querySelectorAll('#certificate .figure').length,
      rows: document.querySelectorAll('#regions-table tr').length - 1,
      verdictPx: parseFloat(getComputedStyle(document.getElementById('verdict')).fontSize),
    };
  });
  assert.ok(r.cert < r.viewport, `certificate at ${r.cert}, viewer at ${r.viewport}`);
  assert.equal(r.verdict, 'NOT DONE');
  assert.ok(r.verdictPx >= 24, `verdict font ${r.verdictPx}px`);
  assert.ok(r.figures >= 7, `${r.figures} figures`);
  assert.equal(r.rows, 4);
});

test('the 3D canvas has non-blank pixels', async () => {
  const share = await nonBlankShare();
  assert.ok(share > 0.01, `only ${(share * 100).toFixed(3)} % of the canvas differs from the background`);
});

test('each region is marked in the colour of its reason at its centroid, and the toggle hides them', async () => {
  const regions = await page.evaluate(() => window.autoscanReport.state().regions);
  assert.equal(regions.length, 4);
  assert.deepEqual(regions.map((r) => r.reason).sort(), ['improving', 'not_scanned', 'too_noisy', 'unreachable']);
  const at = () => page.evaluate((regions) => {
    const { width, data } = window.readCanvas();
    return regions.map((r) => {
      const [x, y] = window.autoscanReport.project(r.centroid);
      const i = 4 * (y * width + x);
      return { reason: r.reason, rgb: [data[i], data[i + 1], data[i + 2]] };
    });
  }, regions);
  const near = (a, b, tol) => a.every((v, k) => Math.abs(v - b[k]) <= tol);
  for (const { reason, rgb } of await at()) {
    assert.ok(near(rgb, REASON_RGB[reason], 6), `${reason}: pixel ${rgb} at its centroid, marker ${REASON_RGB[reason]}`);
  }
  await setChecked('show-regions', false);
  for (const { reason, rgb } of await at()) {
    assert.ok(!near(rgb, REASON_RGB[reason], 30), `${reason}: still ${rgb} with the regions hidden`);
  }
  await setChecked('show-regions', true);
});

test('the model is coloured by confidence: low (red, orange) below, confident (blue) above, with a legend', async () => {
  assert.equal(await page.inputValue('#color-by'), 'f');
  await setChecked('show-regions', false);
  await setChecked('show-views', false);
  const { n, std, low, warmLow, high, coolHigh } = await page.evaluate(() => {
    const { width, height, data } = window.readCanvas();
    // Pixels of the model, and those of the lower and upper thirds of its screen extent.
    let n = 0, yMin = height, yMax = -1;
    const sum = [0, 0, 0], sq = [0, 0, 0];
    for (let y = 0; y < height; ++y) {
      for (let x = 0; x < width; ++x) {
        const i = 4 * (y * width + x);
        if (window.isBackground(data, i)) continue;
        yMin = Math.min(yMin, y); yMax = Math.max(yMax, y);
        ++n;
        for (let k = 0; k < 3; ++k) { sum[k] += data[i + k]; sq[k] += data[i + k] ** 2; }
      }
    }
    const third = (yMax - yMin) / 3;
    let low = 0, warmLow = 0, high = 0, coolHigh = 0;
    for (let y = 0; y < height; ++y) {
      for (let x = 0; x < width; ++x) {
        const i = 4 * (y * width + x);
        if (window.isBackground(data, i)) continue;
        const [r, b] = [data[i], data[i + 2]];
        if (y > yMax - third) { ++low; if (r > b + 40) ++warmLow; }
        if (y < yMin + third) { ++high; if (b > r + 20) ++coolHigh; }
      }
    }
    return { n, std: sq.map((s, k) => Math.sqrt(s / n - (sum[k] / n) ** 2)), low, warmLow, high, coolHigh };
  });
  await setChecked('show-regions', true);
  await setChecked('show-views', true);
  assert.ok(std[0] > 25 && std[2] > 25, `colour spread over the model's ${n} pixels: std ${std.map((v) => v.toFixed(1))}`);
  assert.ok(warmLow / low > 0.5, `${warmLow} of ${low} pixels of the lower third red or orange`);
  assert.ok(coolHigh / high > 0.5, `${coolHigh} of ${high} pixels of the upper third blue`);
  const bar = await page.evaluate(() => {
    const b = document.getElementById('colorbar').getBoundingClientRect();
    const t = document.getElementById('colorbar-threshold').getBoundingClientRect();
    return { w: b.width, at: (t.left + t.width / 2 - b.left) / b.width, note: document.getElementById('colorbar-note').textContent };
  });
  assert.ok(bar.w >= 100, `colour bar ${bar.w}px wide`);
  assert.ok(Math.abs(bar.at - 0.45) < 0.02, `threshold mark at ${bar.at} of the bar, the certificate's 0.45`);
  assert.match(bar.note, /threshold 0\.450/);
});

test('views are frusta: the scanned ones and the next ones, one each', async () => {
  const s = await page.evaluate(() => window.autoscanReport.state());
  assert.equal(s.iteration, 1);
  assert.deepEqual(s.frusta, { next: 2, scanned: 2 });
  const before = await nonBlankShare();
  await setChecked('show-views', false);
  const without = await nonBlankShare();
  await setChecked('show-views', true);
  assert.ok(before > without, `the frusta add pixels (${before} vs ${without})`);
});

test('the slice panel shows a field image, the last earlier one when the iteration has none', async () => {
  const last = await page.evaluate(() => ({
    w: document.getElementById('slice').naturalWidth, shown: getComputedStyle(document.getElementById('slice')).display,
    caption: document.getElementById('slice-caption').textContent,
  }));
  assert.equal(last.w, 32);
  assert.notEqual(last.shown, 'none');
  assert.match(last.caption, /this is iteration 0's/);
  await page.evaluate(() => window.autoscanReport.setIteration(0));
  const first = await page.evaluate(() => ({ w: document.getElementById('slice').naturalWidth, caption: document.getElementById('slice-caption').textContent }));
  assert.equal(first.w, 32);
  assert.match(first.caption, /of iteration 0 on the horizontal layer/);
  await page.evaluate(() => window.autoscanReport.setIteration(1));
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
  assert.equal(after0.regions.length, 0);  // iteration 0 has no certificate
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
  await page.selectOption('#color-by', 'f');
  assert.deepEqual(consoleErrors, []);
});

// Shares of canvas pixels that are clearly red (r ≫ g, b) and clearly blue (b ≫ r, g).
async function redBlueShares() {
  return page.evaluate(() => {
    const { data } = window.readCanvas();
    let red = 0, blue = 0;
    for (let i = 0; i < data.length; i += 4) {
      const [r, g, b] = [data[i], data[i + 1], data[i + 2]];
      if (r > 80 && r > 2.5 * g && r > 2.5 * b) ++red;
      if (b > 80 && b > 2.5 * r && b > 1.8 * g) ++blue;
    }
    return { red: red / (data.length / 4), blue: blue / (data.length / 4) };
  });
}

test('the coloured model renders in its scanned colours and switches back to confidence', async () => {
  // The fixture's last iteration has a coloured model (red above z = 0, blue below).
  const last = (await page.evaluate(() => window.autoscanReport.state())).iterations - 1;
  await page.evaluate((k) => window.autoscanReport.setIteration(k), last);
  await page.evaluate(() => window.autoscanReport.setColorBy('color'));
  assert.equal(await page.inputValue('#color-by'), 'color');
  await setChecked('show-regions', false);
  await setChecked('show-views', false);
  const coloured = await redBlueShares();
  assert.ok(coloured.red > 0.02, `red share ${coloured.red}`);
  assert.ok(coloured.blue > 0.02, `blue share ${coloured.blue}`);
  assert.equal(await page.evaluate(() => getComputedStyle(document.getElementById('legend')).display), 'none');
  const colourSum = await page.evaluate(() => window.autoscanReport.state().meshColorChecksum);
  await page.selectOption('#color-by', 'f');
  const confSum = await page.evaluate(() => window.autoscanReport.state().meshColorChecksum);
  assert.notEqual(colourSum, confSum);
  await page.selectOption('#color-by', 'color');
  assert.equal(await page.evaluate(() => window.autoscanReport.state().meshColorChecksum), colourSum);
  await page.selectOption('#color-by', 'f');
  await setChecked('show-regions', true);
  await setChecked('show-views', true);
  assert.deepEqual(consoleErrors, []);
});

test('plots are drawn, and no legend overlaps its title or another entry', async () => {
  const boxes = await page.evaluate(() => [...document.querySelectorAll('#plots svg')].map((svg) => {
    const box = (el) => { const b = el.getBBox(); return { x: b.x, y: b.y, w: b.width, h: b.height }; };
    return { title: box(svg.querySelector('.plot-title')), entries: [...svg.querySelectorAll('.legend-entry')].map(box), width: Number(svg.getAttribute('width')), name: svg.querySelector('.plot-title').textContent };
  }));
  assert.ok(boxes.length >= 5, `expected at least 5 plots, got ${boxes.length}`);
  const overlap = (a, b) => a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;
  for (const p of boxes) {
    assert.ok(p.entries.length >= 1, `${p.name}: no legend`);
    p.entries.forEach((e, i) => {
      assert.ok(!overlap(e, p.title), `${p.name}: legend entry ${i} ${JSON.stringify(e)} overlaps the title ${JSON.stringify(p.title)}`);
      assert.ok(e.x >= 0 && e.x + e.w <= p.width, `${p.name}: legend entry ${i} leaves the plot`);
      p.entries.slice(i + 1).forEach((f, j) => assert.ok(!overlap(e, f), `${p.name}: legend entries ${i} and ${i + j + 1} overlap`));
    });
  }
});

test('the error histogram has more than 3 non-empty bars (logarithmic bins)', async () => {
  const h = await page.evaluate(() => {
    const svg = document.getElementById('histogram');
    return { bars: [...svg.querySelectorAll('rect.bar')].filter((r) => Number(r.getAttribute('height')) > 0.5).length, text: svg.textContent };
  });
  assert.ok(h.bars > 3, `${h.bars} non-empty bars`);
  assert.match(h.text, /log bins/);
});

for (const width of [1280, 800]) {
  test(`no sideways scroll at ${width} px, the iterations table in view`, async () => {
    const p = await openPage(width);
    await shot(p, `report-${width}-full.png`);
    const r = await p.evaluate(() => {
      const s = document.scrollingElement;
      const table = document.getElementById('iterations-table');
      const t = table.getBoundingClientRect();
      const box = table.parentElement.getBoundingClientRect();
      return { sw: s.scrollWidth, cw: s.clientWidth, tableRight: t.right, boxRight: box.right, canvas: document.querySelector('#viewport canvas').getBoundingClientRect().width };
    });
    await p.close();
    assert.ok(r.sw <= r.cw, `page ${r.sw}px wide in a ${r.cw}px window`);
    assert.ok(r.canvas > 0.5 * width, `3D view only ${r.canvas}px wide`);
    if (width >= 1280) assert.ok(r.tableRight <= r.boxRight + 1, `iterations table cut off: ends at ${r.tableRight}, its box at ${r.boxRight}`);
    assert.deepEqual(consoleErrors, []);
  });
}
