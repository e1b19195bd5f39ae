// autoscan report viewer: reads the data embedded in report.html (a JSON manifest plus base64
// binary buffers), shows one scanning iteration at a time in a three.js scene — the Poisson mesh
// coloured by confidence (split at the certificate's threshold) or f_g, f_s or its scanned colours,
// the certificate's low-confidence regions ringed in the colour of their reason, the views already
// scanned and the next-best views as camera frusta along their paths, the point cloud (this
// iteration's new points highlighted) — and draws the history plots as inline SVG.
// Bundled with esbuild (no network at view time).
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import {
  confidenceColor, confidenceGradient, REASON_COLORS, OTHER_REASON_COLOR, NEXT_VIEW_COLOR, SCANNED_VIEW_COLOR,
  PATH_COLOR, NEW_POINT_COLOR, OLD_POINT_COLOR,
} from './colors.js';
import { plot } from './plot.js';

export { confidenceColor } from './colors.js';

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

// Linear-light RGB of an sRGB colour (vertex colours are linear in three.js' colour management).
const tmpColor = new THREE.Color();
function linear(rgb) {
  tmpColor.setRGB(rgb[0], rgb[1], rgb[2], THREE.SRGBColorSpace);
  return [tmpColor.r, tmpColor.g, tmpColor.b];
}

// A camera frustum (apex at the view's position, a rectangle `len` ahead) as line segments.
function frustumSegments(v, halfFov, len, out) {
  const p = new THREE.Vector3(...v.position);
  const d = new THREE.Vector3(...v.direction).normalize();
  const up = new THREE.Vector3(...(v.up || [0, 0, 1]));
  let right = new THREE.Vector3().crossVectors(d, up);
  if (right.lengthSq() < 1e-12) right = new THREE.Vector3().crossVectors(d, new THREE.Vector3(1, 0, 0));
  right.normalize();
  const u = new THREE.Vector3().crossVectors(right, d).normalize();
  const w = Math.tan(halfFov) * len;
  const corners = [[1, 1], [1, -1], [-1, -1], [-1, 1]].map(([a, b]) =>
    p.clone().addScaledVector(d, len).addScaledVector(right, a * w).addScaledVector(u, b * w * 0.75));
  for (let k = 0; k < 4; ++k) out.push(p, corners[k], corners[k], corners[(k + 1) % 4]);
  // The top edge marked by a small tick, so that up is readable.
  const top = corners[0].clone().add(corners[3]).multiplyScalar(0.5);
  out.push(top, top.clone().addScaledVector(u, w * 0.3));
}

// The slice of iteration k, or of the latest earlier iteration that has one, and the caption.
function sliceOf(iterations, k) {
  const it = iterations[k];
  if (it.slice) return { src: it.slice, caption: `|g| of the viewing vector field (Eq. 4) of iteration ${it.index} on the horizontal layer through the object's centre (jet: low blue, high red; dark grey: inside; white rings: the next views).` };
  for (let j = k - 1; j >= 0; --j) {
    if (iterations[j].slice) {
      const why = (it.views || []).length === 0
        ? `planned no views${it.stop_reason ? ` (stop: ${it.stop_reason})` : ''}, so it has no field`
        : 'has no field slice';
      return { src: iterations[j].slice, caption: `Iteration ${it.index} ${why}: this is iteration ${iterations[j].index}'s, |g| of the viewing vector field (Eq. 4) on the horizontal layer through the object's centre (jet: low blue, high red; white rings: its next views).` };
    }
  }
  return { src: null, caption: `No viewing-field slice: no iteration up to ${it.index} planned views with the Poisson planner (the session directory has no iterations/iter_KKK/field_slice.png).` };
}

export function start() {
  const manifest = JSON.parse(document.getElementById('autoscan-data').textContent);
  const iterations = manifest.iterations;
  const $ = (id) => document.getElementById(id);
  const viewport = $('viewport');
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
  camera.add(sun);  // a head light: the side the user looks at is lit
  sun.position.set(0.5, 1, 0.5);
  scene.add(camera);

  const groups = { cloud: new THREE.Group(), mesh: new THREE.Group(), views: new THREE.Group(), regions: new THREE.Group() };
  Object.values(groups).forEach((g) => scene.add(g));
  // The certificate is the heart of the report: the model opens coloured by confidence.
  const state = { iteration: iterations.length - 1, colorBy: 'f', meshColorChecksum: 0, points: 0, frusta: { next: 0, scanned: 0 }, regions: [] };
  let sceneRadius = 1;

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
      c.traverse?.((o) => { o.geometry?.dispose(); o.material?.dispose(); });
    }
  }

  function buildCloud(it) {
    clear(groups.cloud);
    state.points = 0;
    if (!it.cloud) return;
    const pos = decodeBuffer(it.cloud.positions, Float32Array);
    const isNew = it.cloud.new ? decodeBuffer(it.cloud.new, Uint8Array) : null;
    const n = pos.length / 3;
    const col = new Float32Array(n * 3);
    const fresh = linear(new THREE.Color(NEW_POINT_COLOR).toArray()), old = linear(new THREE.Color(OLD_POINT_COLOR).toArray());
    for (let i = 0; i < n; ++i) col.set(isNew && isNew[i] ? fresh : old, 3 * i);
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    g.setAttribute('color', new THREE.BufferAttribute(col, 3));
    groups.cloud.add(new THREE.Points(g, new THREE.PointsMaterial({ size: 0.005 * sceneRadius, vertexColors: true })));
    state.points = n;
  }

  function threshold(it) {
    return state.colorBy === 'f' ? (it.certificate?.threshold ?? 0.5) : 0.5;
  }

  function meshColors(it) {
    const nv = it.mesh.vertices;
    const col = new Float32Array(nv * 3);
    let sum = 0;
    if (state.colorBy === 'color') {
      // The scanned colours (bytes); grey where the iteration has none.
      const rgb = it.mesh.color ? decodeBuffer(it.mesh.color, Uint8Array) : null;
      for (let i = 0; i < nv; ++i) {
        const c = rgb ? [rgb[3 * i] / 255, rgb[3 * i + 1] / 255, rgb[3 * i + 2] / 255] : [0.6, 0.6, 0.6];
        col.set(linear(c), 3 * i);
        sum += c[0] * 3 + c[1] * 5 + c[2] * 7;
      }
    } else {
      const key = it.mesh.scalars[state.colorBy];
      const s = key ? decodeBuffer(key, Uint8Array) : null;
      const thr = threshold(it);
      for (let i = 0; i < nv; ++i) {
        const c = confidenceColor(s ? s[i] / 255 : 0.5, thr);
        col.set(linear(c), 3 * i);
        sum += c[0] * 3 + c[1] * 5 + c[2] * 7;
      }
    }
    state.meshColorChecksum = sum;
    return col;
  }

  function updateLegend(it) {
    const bar = $('colorbar'), note = $('colorbar-note'), mark = $('colorbar-threshold');
    const scalar = state.colorBy !== 'color';
    $('legend').style.display = scalar ? '' : 'none';
    if (!scalar) return;
    const thr = threshold(it);
    bar.style.background = confidenceGradient(thr);
    mark.style.left = `calc(${(100 * thr).toFixed(2)}% - 1px)`;
    $('colorbar-name').textContent = state.colorBy;
    note.textContent = state.colorBy === 'f' && it.certificate
      ? `the certificate's threshold ${thr.toFixed(3)}: below it (red, orange) the surface is of low confidence`
      : 'split at 0.5';
  }

  function buildMesh(it) {
    clear(groups.mesh);
    updateLegend(it);
    if (!it.mesh) return;
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(decodeBuffer(it.mesh.positions, Float32Array), 3));
    g.setIndex(new THREE.BufferAttribute(decodeBuffer(it.mesh.indices, Uint32Array), 1));
    g.setAttribute('color', new THREE.BufferAttribute(meshColors(it), 3));
    g.computeVertexNormals();
    const opacity = Number($('mesh-opacity').value);
    const m = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ vertexColors: true, side: THREE.DoubleSide,
      transparent: opacity < 1, opacity }));
    groups.mesh.add(m);
  }

  // Frusta of `poses` in `color`, and the path through them (from `start` when given).
  function addFrusta(poses, color, start, pathColor) {
    if (poses.length === 0) return 0;
    const halfFov = ((manifest.scanner?.fov_deg ?? 28) * Math.PI) / 360;
    const len = 0.22 * sceneRadius;
    const lines = [];
    for (const v of poses) {
      frustumSegments(v, halfFov, len, lines);
      if (v.target) lines.push(new THREE.Vector3(...v.position), new THREE.Vector3(...v.target));
    }
    const g = new THREE.BufferGeometry().setFromPoints(lines);
    const frusta = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ color }));
    frusta.userData.frusta = poses.length;
    groups.views.add(frusta);
    const path = [];
    if (start) path.push(new THREE.Vector3(...start.position));
    for (const v of poses) path.push(new THREE.Vector3(...v.position));
    if (path.length > 1) groups.views.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(path), new THREE.LineBasicMaterial({ color: pathColor })));
    return poses.length;
  }

  function buildViews(it) {
    clear(groups.views);
    // The views scanned into this iteration's model (grey), then the next views it planned (green)
    // along their ordered path (orange).
    state.frusta.scanned = addFrusta(it.scans || [], SCANNED_VIEW_COLOR, null, SCANNED_VIEW_COLOR);
    state.frusta.next = addFrusta(it.views || [], NEXT_VIEW_COLOR, it.start, PATH_COLOR);
  }

  // Each certificate region: a ring of its radius facing the camera, and a dot at its centroid, in the
  // colour of its reason, drawn over the model.
  function buildRegions(it) {
    clear(groups.regions);
    state.regions = [];
    for (const r of it.certificate?.regions || []) {
      if (!Array.isArray(r.centroid) || r.centroid.length !== 3) continue;
      const color = REASON_COLORS[r.reason] || OTHER_REASON_COLOR;
      const radius = Math.max(r.radius || 0, 0.02 * sceneRadius);
      const marker = new THREE.Group();
      marker.position.set(...r.centroid);
      const mat = () => new THREE.MeshBasicMaterial({ color, depthTest: false, depthWrite: false, side: THREE.DoubleSide });
      const ring = new THREE.Mesh(new THREE.RingGeometry(radius * 0.86, radius, 64), mat());
      const dot = new THREE.Mesh(new THREE.CircleGeometry(Math.max(0.012 * sceneRadius, 0.12 * radius), 32), mat());
      ring.renderOrder = dot.renderOrder = 10;
      marker.add(ring, dot);
      groups.regions.add(marker);
      state.regions.push({ id: r.id, reason: r.reason, color, centroid: r.centroid, radius });
    }
  }

  function show(k) {
    state.iteration = k;
    const it = iterations[k];
    buildCloud(it);
    buildMesh(it);
    buildViews(it);
    buildRegions(it);
    const regions = it.certificate?.regions?.length;
    $('iteration-label').textContent =
      `iteration ${it.index}: ${it.points ?? '?'} points, ${(it.scans || []).length} scans added, ${(it.views || []).length} next views, mean f ${Number.isFinite(it.mean_f) ? it.mean_f.toFixed(3) : '?'}` +
      (regions !== undefined ? `, ${regions} low-confidence region${regions === 1 ? '' : 's'}` : '');
    const slice = $('slice');
    const s = sliceOf(iterations, k);
    if (s.src) { slice.src = s.src; slice.style.display = ''; } else { slice.removeAttribute('src'); slice.style.display = 'none'; }
    $('slice-caption').textContent = s.caption;
    render();
  }

  function render() {
    groups.cloud.visible = $('show-cloud').checked;
    groups.mesh.visible = $('show-mesh').checked;
    groups.views.visible = $('show-views').checked;
    groups.regions.visible = $('show-regions').checked;
    for (const m of groups.regions.children) m.quaternion.copy(camera.quaternion);
    renderer.render(scene, camera);
  }

  const slider = $('iteration');
  slider.max = String(Math.max(0, iterations.length - 1));
  slider.value = String(state.iteration);
  slider.addEventListener('input', () => show(Number(slider.value)));
  const colorBy = $('color-by');
  if (!manifest.has_color) colorBy.querySelector('option[value="color"]').disabled = true;
  colorBy.value = state.colorBy;
  colorBy.addEventListener('change', () => {
    state.colorBy = colorBy.value;
    const it = iterations[state.iteration];
    updateLegend(it);
    if (it.mesh && groups.mesh.children[0]) {
      groups.mesh.children[0].geometry.setAttribute('color', new THREE.BufferAttribute(meshColors(it), 3));
    }
    render();
  });
  for (const id of ['show-cloud', 'show-mesh', 'show-views', 'show-regions']) $(id).addEventListener('change', render);
  $('mesh-opacity').addEventListener('input', () => { if (iterations[state.iteration]) buildMesh(iterations[state.iteration]); render(); });
  controls.addEventListener('change', render);
  window.addEventListener('resize', () => { resize(); render(); });

  drawPlots(manifest, iterations);

  // Frame the object: look at the centre of the last iteration's mesh (or cloud) from a distance that
  // fits it.
  const last = iterations[iterations.length - 1];
  const framed = last && (last.mesh || last.cloud);
  if (framed) {
    const p = decodeBuffer(framed.positions, Float32Array);
    const box = new THREE.Box3();
    for (let i = 0; i < p.length; i += 3) box.expandByPoint(new THREE.Vector3(p[i], p[i + 1], p[i + 2]));
    const c = box.getCenter(new THREE.Vector3());
    sceneRadius = Math.max(1e-3, box.getSize(new THREE.Vector3()).length() / 2);
    controls.target.copy(c);
    camera.position.copy(c).add(new THREE.Vector3(1.1, -1.4, 0.9).normalize().multiplyScalar(sceneRadius * 2.6));
    camera.near = sceneRadius * 0.01;
    camera.far = sceneRadius * 100;
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
    // Canvas pixel (device pixels, origin top left) of world point p, for the browser tests.
    project: (p) => {
      render();
      const v = new THREE.Vector3(...p).project(camera);
      const c = renderer.domElement;
      return [Math.round(((v.x + 1) / 2) * c.width), Math.round(((1 - v.y) / 2) * c.height)];
    },
  };
}

// The history plots: certificate, confidence, truth, time, the final error histogram.
function drawPlots(manifest, iterations) {
  const P = manifest.plots || {};
  const xs = iterations.map((it) => String(it.index));
  const plots = document.getElementById('plots');
  const has = (k) => Array.isArray(P[k]) && P[k].some((v) => v !== null);
  if (has('share_confident')) {
    plot(plots, 'certificate: share of the surface', xs, [
      { name: 'confident', values: P.share_confident, color: '#2166ac' },
      { name: 'improvable', values: P.share_improvable || [], color: REASON_COLORS.not_scanned },
      { name: 'unreachable', values: P.share_unreachable || [], color: REASON_COLORS.unreachable },
      { name: 'too noisy', values: P.share_too_noisy || [], color: REASON_COLORS.too_noisy },
    ], { min: 0, max: 1, percent: true, xlabel: 'iteration' });
  }
  plot(plots, 'mean confidence', xs, [
    { name: 'f', values: P.mean_f || [], color: '#b91c1c' },
    { name: 'f_g', values: P.mean_f_g || [], color: '#2563eb' },
    { name: 'f_s', values: P.mean_f_s || [], color: '#16a34a' },
  ], { min: 0, max: 1, xlabel: 'iteration' });
  if (has('coverage')) {
    const cov = [{ name: 'coverage of the truth', values: P.coverage, color: '#0891b2' }];
    if (has('coverage_scannable')) cov.push({ name: 'of the scannable surface', values: P.coverage_scannable, color: '#7c3aed' });
    if (has('fscore')) cov.push({ name: 'F-score', values: P.fscore, color: '#ea580c' });
    plot(plots, 'coverage and F-score (truth)', xs, cov, { min: 0, max: 1, xlabel: 'iteration' });
  }
  if (has('accuracy_mean')) {
    plot(plots, 'error vs truth (mean distance)', xs, [
      { name: 'accuracy', values: P.accuracy_mean, color: '#7c3aed' },
      { name: 'completeness', values: P.completeness_mean || [], color: '#ea580c' },
    ], { min: 0, xlabel: 'iteration' });
  }
  if (P.seconds && Object.keys(P.seconds).length) {
    const palette = ['#2563eb', '#16a34a', '#b91c1c', '#ca8a04', '#7c3aed', '#0891b2', '#db2777', '#475569', '#65a30d'];
    plot(plots, 'seconds per stage', xs, Object.entries(P.seconds).map(([k, v], i) => ({ name: k, values: v, color: palette[i % palette.length] })), { bars: true, min: 0, xlabel: 'iteration' });
  }
  const h = manifest.histogram;
  if (h && h.values?.length) {
    const svg = plot(plots, `error histogram, iteration ${iterations[iterations.length - 1].index}`, h.labels,
      [{ name: 'share of samples', values: h.values, color: '#475569' }],
      { bars: true, min: 0, percent: true, xlabel: `distance to the truth / diagonal, bins up to${h.log ? ' (log bins)' : ''}` });
    svg.id = 'histogram';
  }
}

if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', start);
else start();
