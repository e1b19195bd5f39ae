// The report's colours: the confidence map, the marker colour of each certificate reason
// (docs/stop-rule.md), the views'. The certificate table in the page (report.cpp, reason_color) uses
// the same reason colours.

// Confidence map split at the certificate's threshold: below it (what the certificate calls low)
// from dark red (0) through red to orange (just below the threshold); above it from a pale blue
// (just above) to a deep blue (1). The hue jump at the threshold shows where the surface is weak.
const LOW = [[0.0, [0.40, 0.0, 0.12]], [0.5, [0.84, 0.38, 0.30]], [1.0, [0.99, 0.68, 0.38]]];
const HIGH = [[0.0, [0.82, 0.90, 0.95]], [0.5, [0.46, 0.64, 0.84]], [1.0, [0.13, 0.40, 0.67]]];

function ramp(stops, u) {
  for (let i = 1; i < stops.length; ++i) {
    if (u <= stops[i][0]) {
      const [t0, c0] = stops[i - 1];
      const [t1, c1] = stops[i];
      const w = (u - t0) / (t1 - t0);
      return [0, 1, 2].map((k) => c0[k] + w * (c1[k] - c0[k]));
    }
  }
  return stops[stops.length - 1][1].slice();
}

// sRGB colour (0-1 per channel) of value t in [0, 1] with the low/high split at `threshold`.
export function confidenceColor(t, threshold = 0.5) {
  t = Math.min(1, Math.max(0, Number.isFinite(t) ? t : 0));
  const thr = Math.min(0.999, Math.max(0.001, Number.isFinite(threshold) ? threshold : 0.5));
  return t < thr ? ramp(LOW, t / thr) : ramp(HIGH, (t - thr) / (1 - thr));
}

// CSS linear-gradient of the map (for the colour bar legend), sharp at the threshold.
export function confidenceGradient(threshold) {
  const thr = Math.min(0.999, Math.max(0.001, Number.isFinite(threshold) ? threshold : 0.5));
  const css = (t, at) => `rgb(${confidenceColor(t, thr).map((v) => Math.round(255 * v)).join(',')}) ${(100 * at).toFixed(2)}%`;
  const stops = [];
  for (let i = 0; i <= 10; ++i) stops.push(css((thr * i) / 10 - (i === 10 ? 1e-9 : 0), (thr * i) / 10));
  for (let i = 0; i <= 10; ++i) stops.push(css(thr + ((1 - thr) * i) / 10, thr + ((1 - thr) * i) / 10));
  return `linear-gradient(to right, ${stops.join(', ')})`;
}

export const REASON_COLORS = {
  not_scanned: '#7c3aed',
  improving: '#db2777',
  unreachable: '#111827',
  too_noisy: '#a16207',
};
export const OTHER_REASON_COLOR = '#888888';
export const NEXT_VIEW_COLOR = '#1a7f37';
export const SCANNED_VIEW_COLOR = '#64748b';
export const PATH_COLOR = '#d97706';
export const NEW_POINT_COLOR = '#d91a1a';
export const OLD_POINT_COLOR = '#5a5a66';
