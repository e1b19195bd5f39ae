// Opens a report in headless Chromium, prints the time until the viewer is ready, saves a screenshot.
// Usage: node report/bench/open-time.mjs /abs/path/report.html out.png
import { chromium } from 'playwright-core';
const b = await chromium.launch({ executablePath: '/usr/bin/chromium', headless: true, args: ['--no-sandbox','--use-angle=swiftshader','--enable-unsafe-swiftshader','--disable-background-networking','--disable-component-update','--disable-sync','--no-first-run'] });
const p = await b.newPage({ viewport: { width: 1400, height: 1000 } });
const errs = [];
p.on('console', m => { if (m.type()==='error') errs.push(m.text()); });
const t0 = Date.now();
await p.goto('file://' + process.argv[2]);
await p.waitForFunction(() => window.autoscanReport && window.autoscanReport.ready, null, {timeout: 60000});
console.log('load ms', Date.now() - t0, 'errors', errs);
await p.screenshot({ path: process.argv[3], fullPage: true });
await b.close();
