// Small line and bar plots as inline SVG. The title sits on the first line, the legend below it
// (wrapped onto as many lines as it needs), the plot area below the legend: they never overlap.

function svgEl(tag, attrs, parent) {
  const el = document.createElementNS('http://www.w3.org/2000/svg', tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  if (parent) parent.appendChild(el);
  return el;
}

export function fmt(v) {
  if (v === 0) return '0';
  if (Math.abs(v) >= 100) return v.toFixed(0);
  if (Math.abs(v) >= 1) return v.toFixed(2);
  return v.toPrecision(2);
}

const W = 360, L = 48, R = 12, B = 32, TITLE_H = 22, LEGEND_ROW = 14, PLOT_H = 150;
const CHAR_W = 6.2;  // width of a 10 px tick character, generously

// Places the legend entries left to right, wrapping at the plot's width; returns the rows used.
function legend(svg, series) {
  let x = L, row = 0;
  series.forEach((s) => {
    const w = 16 + CHAR_W * s.name.length + 12;
    if (x + w > W - R && x > L) { x = L; ++row; }
    const y = TITLE_H + row * LEGEND_ROW;
    const g = svgEl('g', { class: 'legend-entry' }, svg);
    svgEl('rect', { x, y, width: 10, height: 10, fill: s.color }, g);
    svgEl('text', { x: x + 14, y: y + 9, class: 'tick' }, g).textContent = s.name;
    x += w;
  });
  return series.length ? row + 1 : 0;
}

// series: [{name, values, color}], x: labels. opts: {min, max, bars, xlabel, percent}.
export function plot(container, title, x, series, opts = {}) {
  const svg = svgEl('svg', { class: 'plot' });
  svgEl('text', { x: W / 2, y: 15, 'text-anchor': 'middle', class: 'plot-title' }, svg).textContent = title;
  const rows = legend(svg, series);
  const T = TITLE_H + rows * LEGEND_ROW + 6;
  const H = T + PLOT_H + B + (opts.xlabel ? 12 : 0);
  svg.setAttribute('width', W);
  svg.setAttribute('height', H);
  svg.setAttribute('viewBox', `0 0 ${W} ${H}`);
  const all = series.flatMap((s) => s.values.filter((v) => v !== null && Number.isFinite(v)));
  if (all.length === 0) {
    svgEl('text', { x: W / 2, y: T + PLOT_H / 2, 'text-anchor': 'middle' }, svg).textContent = 'no data';
    container.appendChild(svg);
    return svg;
  }
  let lo = opts.min ?? Math.min(...all), hi = opts.max ?? Math.max(...all);
  if (hi - lo < 1e-12) hi = lo + 1;
  const n = x.length;
  const base = T + PLOT_H;
  const px = (i) => (opts.bars ? L + ((i + 0.5) * (W - L - R)) / n : L + (n <= 1 ? (W - L - R) / 2 : (i * (W - L - R)) / (n - 1)));
  const py = (v) => T + PLOT_H * (1 - (v - lo) / (hi - lo));
  svgEl('line', { x1: L, y1: base, x2: W - R, y2: base, stroke: '#888' }, svg);
  svgEl('line', { x1: L, y1: T, x2: L, y2: base, stroke: '#888' }, svg);
  const tick = (v) => (opts.percent ? `${fmt(100 * v)} %` : fmt(v));
  for (const v of [lo, (lo + hi) / 2, hi]) {
    svgEl('line', { x1: L, y1: py(v), x2: W - R, y2: py(v), stroke: '#eee' }, svg);
    svgEl('text', { x: L - 4, y: py(v) + 4, 'text-anchor': 'end', class: 'tick' }, svg).textContent = tick(v);
  }
  const every = Math.max(1, Math.ceil((n * CHAR_W * Math.max(...x.map((s) => String(s).length), 1)) / (W - L - R - 10)));
  x.forEach((lab, i) => {
    if (i % every !== 0) return;
    svgEl('text', { x: px(i), y: base + 14, 'text-anchor': 'middle', class: 'tick' }, svg).textContent = lab;
  });
  if (opts.xlabel) svgEl('text', { x: (L + W - R) / 2, y: base + 28, 'text-anchor': 'middle', class: 'tick' }, svg).textContent = opts.xlabel;
  if (opts.bars) {
    const bw = Math.max(1, (W - L - R) / Math.max(1, n) / series.length - 1);
    series.forEach((s, k) => s.values.forEach((v, i) => {
      if (v === null || !Number.isFinite(v)) return;
      const x0 = px(i) - (series.length * bw) / 2 + k * bw;
      svgEl('rect', { x: x0, y: py(v), width: bw, height: Math.max(0, base - py(v)), fill: s.color, class: 'bar' }, svg);
    }));
  } else {
    series.forEach((s) => {
      const pts = s.values.map((v, i) => (v === null || !Number.isFinite(v) ? null : `${px(i)},${py(v)}`)).filter(Boolean);
      svgEl('polyline', { points: pts.join(' '), fill: 'none', stroke: s.color, 'stroke-width': 2 }, svg);
      s.values.forEach((v, i) => { if (v !== null && Number.isFinite(v)) svgEl('circle', { cx: px(i), cy: py(v), r: 3, fill: s.color }, svg); });
    });
  }
  container.appendChild(svg);
  return svg;
}
