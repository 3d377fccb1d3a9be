// zeromode designer, beyond one motion (issue #41): charts drawn from what the service answered,
// nothing recomputed here. The energy landscape of a multistable design (POST
// /v1/design/multistable: E along the motion, its minima and barriers, a cursor at the animation's
// sample) and the map of a chained module (POST /v1/design/sequential, POST /v1/map: f, the
// diagonal, fixed points and folds, the chain's distances d_0 … d_n at the animation's sample as a
// cobweb, and d_k along the chain). Loaded before designer.js, whose helpers (el, fmt) it uses.
"use strict";

const CHART = { spring: "#b15928", pair: "#e7298a", energy: "#333333", minimum: "#1a9850", barrier: "#d73027",
                cursor: "#1283d4", diagonal: "#bbbbbb", map: "#333333", cobweb: "#e7298a", wall: "#6a3d9a" };
const CONFORMATION_COLOURS = ["#1b9e77", "#7570b3", "#e6ab02"];

// A spring between two points of the page: a zig-zag of TEETH teeth, AMPLITUDE px across,
// with straight leads (a fifth of its length at each end), as springs are drawn in the paper.
const TEETH = 7, AMPLITUDE = 4;
function springPath([x1, y1], [x2, y2]) {
  const dx = x2 - x1, dy = y2 - y1, length = Math.hypot(dx, dy) || 1;
  const nx = -dy / length, ny = dx / length;
  const at = (f, side) => [x1 + f * dx + side * AMPLITUDE * nx, y1 + f * dy + side * AMPLITUDE * ny];
  const points = [[x1, y1], at(0.2, 0)];
  for (let t = 0; t < 2 * TEETH; t++) points.push(at(0.2 + 0.6 * (t + 0.5) / (2 * TEETH), t % 2 ? -1 : 1));
  points.push(at(0.8, 0), [x2, y2]);
  return points.map(([x, y], i) => `${i ? "L" : "M"}${x.toFixed(1)} ${y.toFixed(1)}`).join("");
}

// A chart's frame: world box → SVG box, axes with end labels; returns the maps.
function chartAxes(svg, box, [xlo, xhi], [ylo, yhi], xlabel, ylabel, xends = [fmt(xlo, 3), fmt(xhi, 3)]) {
  const X = (v) => box.left + (box.right - box.left) * (v - xlo) / ((xhi - xlo) || 1);
  const Y = (v) => box.bottom - (box.bottom - box.top) * (v - ylo) / ((yhi - ylo) || 1);
  el("line", { x1: box.left, y1: box.bottom, x2: box.right, y2: box.bottom, stroke: "#888" }, svg);
  el("line", { x1: box.left, y1: box.top, x2: box.left, y2: box.bottom, stroke: "#888" }, svg);
  const text = (x, y, s, anchor, extra = {}) => {
    el("text", { x, y, "font-size": 11, "text-anchor": anchor, fill: "#444", ...extra }, svg).textContent = s;
  };
  text(box.left - 4, box.top + 4, fmt(yhi, 3), "end");
  text(box.left - 4, box.bottom + 3, fmt(ylo, 3), "end");
  text(box.left, box.bottom + 14, xends[0], "start");
  text(box.right, box.bottom + 14, xends[1], "end");
  text((box.left + box.right) / 2, box.bottom + 14, xlabel, "middle");
  text(box.left - 30, (box.top + box.bottom) / 2, ylabel, "middle",
       { transform: `rotate(-90 ${box.left - 30} ${(box.top + box.bottom) / 2})` });
  return { X, Y, text };
}

// An energy chart: E (e, one per sample) against x (one per sample), and the cursor at sample k
// of the animation; returns the chart's maps for what is drawn over it.
function energyCurve(svg, x, e, k, xlabel, ylabel, xends) {
  svg.replaceChildren();
  const yhi = 1.12 * (Math.max(...e) || 1);
  const axes = chartAxes(svg, { left: 56, right: 785, top: 12, bottom: 150 }, [x[0], x[x.length - 1]], [0, yhi], xlabel, ylabel, xends);
  const { X, Y } = axes;
  el("polyline", { class: "energy", points: x.map((v, i) => `${X(v).toFixed(1)},${Y(e[i]).toFixed(1)}`).join(" "),
                   fill: "none", stroke: CHART.energy, "stroke-width": 2 }, svg);
  el("line", { class: "cursor", "data-testid": "landscape-cursor", "data-sample": k, x1: X(x[k]), y1: 12, x2: X(x[k]), y2: 150,
               stroke: CHART.cursor, "stroke-width": 1.5 }, svg);
  el("circle", { class: "cursor-dot", cx: X(x[k]), cy: Y(e[k]), r: 4, fill: CHART.cursor }, svg);
  return axes;
}

// The energy landscape E(s) under the drawing: the curve, each minimum (a green dot per body
// minimum), each barrier (the highest sample between neighbouring minima, a red triangle with
// its height above the higher of the two), and the cursor at sample k of the animation.
function drawLandscape(svg, body, k) {
  // Drawn above the lowest sample: the landscape's shape is in differences far smaller than E.
  const land = body.landscape, s = land.arclength, low = Math.min(...land.energy), e = land.energy.map((v) => v - low);
  const { X, Y, text } = energyCurve(svg, s, e, k, "arc length s along the motion", "E − E_min");
  const at = land.conformation_samples;
  for (let c = 0; c + 1 < at.length; c++) {
    let top = at[c];
    for (let i = at[c]; i <= at[c + 1]; i++) if (e[i] > e[top]) top = i;
    const base = Math.max(e[at[c]], e[at[c + 1]]), x = X(s[top]);
    el("line", { class: "barrier-height", x1: x, y1: Y(base), x2: x, y2: Y(e[top]), stroke: CHART.barrier, "stroke-dasharray": "3 3" }, svg);
    el("polygon", { class: "barrier", "data-sample": top, points: `${x - 6},${Y(e[top]) - 9} ${x + 6},${Y(e[top]) - 9} ${x},${Y(e[top]) - 1}`,
                    fill: CHART.barrier }, svg);
    text(x + 8, Y(e[top]) + 4, `ΔE ${fmt(e[top] - base, 3)}`, "start", { fill: CHART.barrier });
  }
  body.minima.forEach((m, c) => {
    const x = X(m.arclength), y = Y(m.energy - low);
    el("circle", { class: "minimum", "data-index": m.index, cx: x, cy: y, r: 6, fill: CONFORMATION_COLOURS[c % 3], stroke: "#fff", "stroke-width": 1.5 }, svg);
    text(x, y + 20, `${m.index + 1}`, "middle", { "font-weight": "bold", fill: CONFORMATION_COLOURS[c % 3] });
  });
}

// A soliton's energy along its drive (the animation's samples, body.soliton.energy) against
// |d_0 − d_u| on a log axis, from the stable end (left) to the unstable one; the uniform states'
// E = 0 as a dashed line (both are minima), the cursor at sample k.
function drawDriveEnergy(svg, motion, k) {
  const x = motion.offset.map(Math.log10), e = motion.energy;
  const ends = [x[0], x[x.length - 1]].map((v) => fmt(10 ** v, 2));
  const { X, Y } = energyCurve(svg, x, e, k, "drive |d₀ − d_u| (log scale), the input driven towards d_u →", "E (k·L²)", ends);
  el("line", { class: "uniform-level", x1: X(x[0]), y1: Y(0), x2: X(x[x.length - 1]), y2: Y(0), stroke: CHART.minimum, "stroke-dasharray": "4 3" }, svg);
}

// The module's map f (samples of the body's map), the diagonal, fixed points (filled: stable),
// the usable range's ends (a bar across at a fold), and the cobweb of d = distances[k]:
// (d_0, d_0) → (d_0, d_1) → (d_1, d_1) → … — the chain at the animation's sample is an orbit of f.
function drawMapChart(svg, map, d) {
  svg.replaceChildren();
  const lo = Math.min(map.lower.d_in, ...map.d_out, ...(d || [])), hi = Math.max(map.upper.d_in, ...map.d_out, ...(d || []));
  const pad = 0.04 * (hi - lo), range = [lo - pad, hi + pad];
  const { X, Y } = chartAxes(svg, { left: 48, right: 290, top: 10, bottom: 252 }, range, range, "d_in", "d_out = f(d_in)");
  el("line", { class: "diagonal", x1: X(range[0]), y1: Y(range[0]), x2: X(range[1]), y2: Y(range[1]), stroke: CHART.diagonal, "stroke-dasharray": "4 3" }, svg);
  el("polyline", { class: "map", points: map.d_in.map((v, i) => `${X(v).toFixed(1)},${Y(map.d_out[i]).toFixed(1)}`).join(" "),
                   fill: "none", stroke: CHART.map, "stroke-width": 2 }, svg);
  for (const end of [map.lower, map.upper]) {
    el("line", { class: `end ${end.kind}`, x1: X(end.d_in) - 5, y1: Y(end.d_out), x2: X(end.d_in) + 5, y2: Y(end.d_out),
                 stroke: "#555", "stroke-width": 3 }, svg).appendChild(titled(`${end.kind} at d_in = ${fmt(end.d_in, 4)}`));
  }
  if (d && d.length > 1) {
    const pts = [[d[0], d[0]]];
    for (let i = 0; i + 1 < d.length; i++) pts.push([d[i], d[i + 1]], [d[i + 1], d[i + 1]]);
    el("polyline", { class: "cobweb", "data-testid": "cobweb", points: pts.map(([a, b]) => `${X(a).toFixed(2)},${Y(b).toFixed(2)}`).join(" "),
                     fill: "none", stroke: CHART.cobweb, "stroke-width": 1.2 }, svg);
    el("circle", { class: "cobweb-start", cx: X(d[0]), cy: Y(d[0]), r: 3.5, fill: CHART.cobweb }, svg);
  }
  for (const p of map.fixed_points) {
    el("circle", { class: "fixed-point", cx: X(p.d), cy: Y(p.d), r: 5, fill: p.stable ? "#000" : "#fff", stroke: "#000", "stroke-width": 1.5 }, svg)
      .appendChild(titled(`fixed point d* = ${fmt(p.d, 4)}, f′ = ${fmt(p.slope, 3)} (${p.stable ? "stable" : "unstable"})`));
  }
}

// d_k along the chain at the animation's sample (bars), with the fixed points as lines across;
// for a soliton ({wall, d_u, d_s}), the wall (its fractional index w, a vertical line; none when
// null) and the level where the switched fraction is ½ (midway between d_u's and d_s's, dotted).
function drawProfile(svg, map, d, soliton) {
  svg.replaceChildren();
  const lo = Math.min(map.lower.d_in, ...d), hi = Math.max(map.upper.d_in, ...d);
  const { X, Y } = chartAxes(svg, { left: 48, right: 290, top: 10, bottom: 252 }, [-0.5, d.length - 0.5], [Math.min(0, lo), hi],
                             "pair k along the chain", "d_k", ["0", String(d.length - 1)]);
  for (const p of map.fixed_points) {
    el("line", { class: "fixed-level", x1: X(-0.5), y1: Y(p.d), x2: X(d.length - 0.5), y2: Y(p.d), stroke: "#999", "stroke-dasharray": p.stable ? "" : "4 3" }, svg);
  }
  const w = Math.max(1, 0.7 * (X(1) - X(0)));
  d.forEach((v, k) => el("rect", { class: "distance", x: X(k) - w / 2, y: Y(v), width: w, height: Y(Math.min(0, lo)) - Y(v), fill: CHART.pair, opacity: 0.75 }, svg));
  if (!soliton) return;
  const half = (Y(soliton.d_u) + Y(soliton.d_s)) / 2, wall = soliton.wall;
  el("line", { class: "half-level", x1: X(-0.5), y1: half, x2: X(d.length - 0.5), y2: half, stroke: CHART.wall, "stroke-dasharray": "1 3" }, svg);
  if (wall === null) return;
  el("line", { class: "wall", "data-testid": "profile-wall", "data-wall": wall, x1: X(wall), y1: 10, x2: X(wall), y2: 252, stroke: CHART.wall, "stroke-width": 2 }, svg);
  el("text", { x: X(wall) + 4, y: 22, "font-size": 11, fill: CHART.wall }, svg).textContent = `wall ${wall.toFixed(2)}`;
}

function titled(text) {
  const t = document.createElementNS("http://www.w3.org/2000/svg", "title");
  t.textContent = text;
  return t;
}
