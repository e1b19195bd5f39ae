// autoscan report viewer: reads the data embedded in report.html (a JSON manifest plus base64
// binary buffers), shows one scanning iteration at a time in a three.js scene — the point cloud
// (this iteration's new points highlighted), the Poisson mesh coloured by f, f_g or f_s, the
// next-best views as frusta along their ordered path — and draws the plots as inline SVG.
// Bundled with esbuild into dist/viewer.bundle.js (no network at view time).
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const bufferCache = new Map();

function decodeBuffer(id, Type) {
  const key = id + ':' + Type.name;
  if (bufferCache.has(key)) return bufferCache.get(key);
  const el = document.getElementById(id);
  if (!el) throw new Error('missing buffer ' + id);
  const bin = atob(el.textContent.trim());
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) bytes[i] = bin.charCodeAt(i);
  const arr = new Type(bytes.buffer, 0, bytes.byteLength / Type.BYTES_PER_ELEMENT);
  bufferCache.set(key, arr);
  return arr;
}

// Blue (low confidence) to red (high), as the paper's figures; same map as autoscan::colormap.
export function colormap(t) {
  t = Math.min(1, Math.max(0, Number.isFinite(t) ? t : 0));
  const stops = [
    [0.0, [0.23, 0.30, 0.75]],
    [0.5, [0.87, 0.87, 0.87]],
    [1.0, [0.71, 0.02, 0.15]],
  ];
  for (let i = 1; i < stops.length; ++i) {
    if (t <= stops[i][0]) {
      const [t0, c0] = stops[i - 1];
      const [t1, c1] = stops[i];
      const u = (t - t0) / (t1 - t0);
      return [0, 1, 2].map((k) => c0[k] + u * (c1[k] - c0[k]));
    }
  }
  return stops[stops.length - 1][1];
}

function svgEl(tag, attrs, parent) {
  const el = document.createElementNS('http://www.w3.org/2000/svg', tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  if (parent) parent.appendChild(el);
  return el;
}

// A small line/bar plot in SVG. series: [{name, values, color}], x: labels.
function plot(container, title, x, series, opts = {}) {
  const W = 360, H = 200, L = 44, R = 10, T = 24, B = 30;
  const svg = svgEl('svg', { width: W, height: H, viewBox: `0 0 ${W} ${H}`, class: 'plot' });
  svgEl('text', { x: W / 2, y: 15, 'text-anchor': 'middle', class: 'plot-title' }, svg).textContent = title;
  const all = series.flatMap((s) => s.values.filter((v) => v !== null && Number.isFinite(v)));
  if (all.length === 0) {
    svgEl('text', { x: W / 2, y: H / 2, 'text-anchor': 'middle' }, svg).textContent = 'no data';
    container.appendChild(svg);
    return svg;
  }
  let lo = opts.min ?? Math.min(...all), hi = opts.max ?? Math.max(...all);
  if (hi - lo < 1e-12) { hi = lo + 1; }
  const n = x.length;
  const px = (i) => L + (n <= 1 ? (W - L - R) / 2 : (i * (W - L - R)) / (n - 1));
  const py = (v) => T + (H - T - B) * (1 - (v - lo) / (hi - lo));
  svgEl('line', { x1: L, y1: H - B, x2: W - R, y2: H - B, stroke: '#888' }, svg);
  svgEl('line', { x1: L, y1: T, x2: L, y2: H - B, stroke: '#888' }, svg);
  for (const v of [lo, (lo + hi) / 2, hi]) {
    svgEl('text', { x: L - 4, y: py(v) + 4, 'text-anchor': 'end', class: 'tick' }, svg).textContent = fmt(v);
  }
  x.forEach((lab, i) => {
    if (n > 12 && i % Math.ceil(n / 12) !== 0) return;
    svgEl('text', { x: px(i), y: H - B + 14, 'text-anchor': 'middle', class: 'tick' }, svg).textContent = lab;
  });
  if (opts.bars) {
    const bw = Math.max(2, (W - L - R) / Math.max(1, n) / series.length - 2);
    series.forEach((s, k) => s.values.forEach((v, i) => {
      if (v === null || !Number.isFinite(v)) return;
      const x0 = L + ((i + 0.5) * (W - L - R)) / n - (series.length * bw) / 2 + k * bw;
      svgEl('rect', { x: x0, y: py(v), width: bw, height: Math.max(0, H - B - py(v)), fill: s.color }, svg);
    }));
  } else {
    series.forEach((s) => {
      const pts = s.values.map((v, i) => (v === null || !Number.isFinite(v) ? null : `${px(i)},${py(v)}`)).filter(Boolean);
      svgEl('polyline', { points: pts.join(' '), fill: 'none', stroke: s.color, 'stroke-width': 2 }, svg);
      s.values.forEach((v, i) => { if (v !== null && Number.isFinite(v)) svgEl('circle', { cx: px(i), cy: py(v), r: 3, fill: s.color }, svg); });
    });
  }
  series.forEach((s, k) => {
    svgEl('rect', { x: L + 6 + k * 90, y: T - 2, width: 10, height: 10, fill: s.color }, svg);
    svgEl('text', { x: L + 20 + k * 90, y: T + 7, class: 'tick' }, svg).textContent = s.name;
  });
  container.appendChild(svg);
  return svg;
}

function fmt(v) {
  if (Math.abs(v) >= 100) return v.toFixed(0);
  if (Math.abs(v) >= 1) return v.toFixed(2);
  return v.toPrecision(2);
}

export function start() {
  const manifest = JSON.parse(document.getElementById('autoscan-data').textContent);
  const iterations = manifest.iterations;
  const viewport = document.getElementById('viewport');
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(0xf4f4f4);
  viewport.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
  camera.up.set(0, 0, 1);
  camera.position.set(1.8, -2.2, 1.4);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.target.set(0, 0, 0);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 1.4);
  sun.position.set(2, -3, 4);
  scene.add(sun);

  const groups = { cloud: new THREE.Group(), mesh: new THREE.Group(), views: new THREE.Group() };
  Object.values(groups).forEach((g) => scene.add(g));
  // A coloured model (docs/colour.md) is shown in its colours first; the select switches to f.
  const state = { iteration: iterations.length - 1, colorBy: manifest.has_color ? 'color' : 'f', meshColorChecksum: 0, points: 0 };

  function resize() {
    const w = viewport.clientWidth || 800, h = viewport.clientHeight || 600;
    renderer.setSize(w, h, false);
    renderer.domElement.style.width = '100%';
    renderer.domElement.style.height = '100%';
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }

  function clear(group) {
    for (const c of [...group.children]) {
      group.remove(c);
      c.geometry?.dispose();
      c.material?.dispose();
    }
  }

  function buildCloud(it) {
    clear(groups.cloud);
    if (!it.cloud) return;
    const pos = decodeBuffer(it.cloud.positions, Float32Array);
    const isNew = it.cloud.new ? decodeBuffer(it.cloud.new, Uint8Array) : null;
    const n = pos.length / 3;
    const col = new Float32Array(n * 3);
    for (let i = 0; i < n; ++i) {
      const c = isNew && isNew[i] ? [0.85, 0.1, 0.1] : [0.35, 0.35, 0.4];
      col.set(c, 3 * i);
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    g.setAttribute('color', new THREE.BufferAttribute(col, 3));
    groups.cloud.add(new THREE.Points(g, new THREE.PointsMaterial({ size: 0.0035, vertexColors: true })));
    state.points = n;
  }

  function meshColors(it) {
    const nv = it.mesh.vertices;
    const col = new Float32Array(nv * 3);
    let sum = 0;
    if (state.colorBy === 'color') {
      // The scanned colours (0-1 RGB); grey where the iteration has none.
      const rgb = it.mesh.color ? decodeBuffer(it.mesh.color, Float32Array) : null;
      for (let i = 0; i < nv; ++i) {
        const c = rgb ? [rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]] : [0.6, 0.6, 0.6];
        col.set(c, 3 * i);
        sum += c[0] * 3 + c[1] * 5 + c[2] * 7;
      }
      state.meshColorChecksum = sum;
      return col;
    }
    const key = it.mesh.scalars[state.colorBy];
    const s = key ? decodeBuffer(key, Float32Array) : null;
    for (let i = 0; i < nv; ++i) {
      const c = colormap(s ? s[i] : 0.5);
      col.set(c, 3 * i);
      sum += c[0] * 3 + c[1] * 5 + c[2] * 7;
    }
    state.meshColorChecksum = sum;
    return col;
  }

  function buildMesh(it) {
    clear(groups.mesh);
    if (!it.mesh) return;
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(decodeBuffer(it.mesh.positions, Float32Array), 3));
    g.setIndex(new THREE.BufferAttribute(decodeBuffer(it.mesh.indices, Uint32Array), 1));
    g.setAttribute('color', new THREE.BufferAttribute(meshColors(it), 3));
    g.computeVertexNormals();
    const m = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide,
      transparent: true, opacity: Number(document.getElementById('mesh-opacity').value) }));
    groups.mesh.add(m);
  }

  function buildViews(it) {
    clear(groups.views);
    const views = it.views || [];
    if (views.length === 0) return;
    const lines = [];
    const half = Math.tan(((manifest.scanner?.fov_deg ?? 28) * Math.PI) / 360);
    const len = 0.18;
    for (const v of views) {
      const p = new THREE.Vector3(...v.position);
      const d = new THREE.Vector3(...v.direction).normalize();
      const up = new THREE.Vector3(...(v.up || [0, 0, 1]));
      const right = new THREE.Vector3().crossVectors(d, up).normalize();
      const u = new THREE.Vector3().crossVectors(right, d).normalize();
      const corners = [[1, 1], [1, -1], [-1, -1], [-1, 1]].map(([a, b]) =>
        p.clone().addScaledVector(d, len).addScaledVector(right, a * half * len).addScaledVector(u, b * half * len * 0.75));
      for (let k = 0; k < 4; ++k) {
        lines.push(p, corners[k], corners[k], corners[(k + 1) % 4]);
      }
      if (v.target) lines.push(p, new THREE.Vector3(...v.target));
    }
    const g = new THREE.BufferGeometry().setFromPoints(lines);
    groups.views.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color: 0x1a7f37 })));
    const path = [];
    if (it.start) path.push(new THREE.Vector3(...it.start.position));
    for (const v of views) path.push(new THREE.Vector3(...v.position));
    const pg = new THREE.BufferGeometry().setFromPoints(path);
    groups.views.add(new THREE.Line(pg, new THREE.LineBasicMaterial({ color: 0xd97706 })));
  }

  function show(k) {
    state.iteration = k;
    const it = iterations[k];
    buildCloud(it);
    buildMesh(it);
    buildViews(it);
    document.getElementById('iteration-label').textContent =
      `iteration ${it.index} — ${it.points ?? '?'} points, ${(it.views || []).length} next views, mean f ${it.mean_f !== undefined ? it.mean_f.toFixed(3) : '?'}`;
    const slice = document.getElementById('slice');
    if (it.slice) { slice.src = it.slice; slice.style.display = ''; } else { slice.style.display = 'none'; }
    render();
  }

  function render() {
    groups.cloud.visible = document.getElementById('show-cloud').checked;
    groups.mesh.visible = document.getElementById('show-mesh').checked;
    groups.views.visible = document.getElementById('show-views').checked;
    renderer.render(scene, camera);
  }

  const slider = document.getElementById('iteration');
  slider.max = String(Math.max(0, iterations.length - 1));
  slider.value = String(state.iteration);
  slider.addEventListener('input', () => show(Number(slider.value)));
  const colorBy = document.getElementById('color-by');
  colorBy.value = state.colorBy;
  colorBy.addEventListener('change', () => {
    state.colorBy = colorBy.value;
    const it = iterations[state.iteration];
    if (it.mesh && groups.mesh.children[0]) {
      groups.mesh.children[0].geometry.setAttribute('color', new THREE.BufferAttribute(meshColors(it), 3));
    }
    render();
  });
  for (const id of ['show-cloud', 'show-mesh', 'show-views']) document.getElementById(id).addEventListener('change', render);
  document.getElementById('mesh-opacity').addEventListener('input', () => { if (iterations[state.iteration]) buildMesh(iterations[state.iteration]); render(); });
  controls.addEventListener('change', render);
  window.addEventListener('resize', () => { resize(); render(); });

  // Plots.
  const P = manifest.plots || {};
  const xs = iterations.map((it) => String(it.index));
  const plots = document.getElementById('plots');
  plot(plots, 'mean confidence', xs, [
    { name: 'f', values: P.mean_f || [], color: '#b91c1c' },
    { name: 'f_g', values: P.mean_f_g || [], color: '#2563eb' },
    { name: 'f_s', values: P.mean_f_s || [], color: '#16a34a' },
  ], { min: 0, max: 1 });
  if (P.accuracy_mean && P.accuracy_mean.some((v) => v !== null)) {
    plot(plots, 'error vs truth (mean distance)', xs, [
      { name: 'accuracy', values: P.accuracy_mean, color: '#7c3aed' },
      { name: 'completeness', values: P.completeness_mean || [], color: '#ea580c' },
    ]);
    plot(plots, 'coverage of the truth', xs, [{ name: 'coverage', values: P.coverage || [], color: '#0891b2' }], { min: 0, max: 1 });
  }
  if (P.seconds) {
    const palette = ['#2563eb', '#16a34a', '#b91c1c', '#ca8a04', '#7c3aed', '#0891b2', '#db2777'];
    plot(plots, 'seconds per stage', xs, Object.entries(P.seconds).map(([k, v], i) => ({ name: k, values: v, color: palette[i % palette.length] })), { bars: true, min: 0 });
  }
  if (manifest.histogram && manifest.histogram.values?.length) {
    plot(plots, 'error histogram (final)', manifest.histogram.labels, [{ name: 'share', values: manifest.histogram.values, color: '#475569' }], { bars: true, min: 0 });
  }

  // Frame the object: look at the centre of the last iteration's cloud from a distance that fits it.
  const last = iterations[iterations.length - 1];
  if (last && last.cloud) {
    const p = decodeBuffer(last.cloud.positions, Float32Array);
    const box = new THREE.Box3();
    for (let i = 0; i < p.length; i += 3) box.expandByPoint(new THREE.Vector3(p[i], p[i + 1], p[i + 2]));
    const c = box.getCenter(new THREE.Vector3());
    const r = Math.max(1e-3, box.getSize(new THREE.Vector3()).length() / 2);
    controls.target.copy(c);
    camera.position.copy(c).add(new THREE.Vector3(1.1, -1.4, 0.9).normalize().multiplyScalar(r * 3.2));
    controls.update();
  }
  resize();
  show(state.iteration);
  window.autoscanReport = {
    ready: true,
    state: () => ({ ...state, iterations: iterations.length }),
    setIteration: (k) => { slider.value = String(k); show(k); },
    setColorBy: (v) => { colorBy.value = v; colorBy.dispatchEvent(new Event('change')); },
    render,
  };
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', start);
else start();
