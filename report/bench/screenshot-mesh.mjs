// Opens a report in headless Chromium with the points hidden and the mesh opaque, saves a screenshot
// (docs/images/colour-report.png). Usage: node report/bench/screenshot-mesh.mjs /abs/report.html out.png
import { chromium } from 'playwright-core';
const b = await chromium.launch({ executablePath: '/usr/bin/chromium', headless: true, args: ['--no-sandbox','--use-angle=swiftshader','--enable-unsafe-swiftshader','--disable-background-networking','--disable-component-update','--disable-sync','--no-first-run'] });
const p = await b.newPage({ viewport: { width: 1400, height: 1000 } });
await p.goto('file://' + process.argv[2]);
await p.waitForFunction(() => window.autoscanReport && window.autoscanReport.ready, null, {timeout: 60000});
await p.evaluate(() => { document.getElementById('show-cloud').checked = false; const o = document.getElementById('mesh-opacity'); o.value = '1'; o.dispatchEvent(new Event('input')); window.autoscanReport.render(); });
await p.screenshot({ path: process.argv[3], fullPage: true });
await b.close();
