// zeromode viewer: design a frame through the REST API, draw it, play its finite motion, export it.
// Plain JavaScript and SVG, no dependencies: the page talks to the service that serves it.
"use strict";

const COLOURS = {
  specified: ["#d7301f", "#8c1d12"], unspecified: ["#2c7fb8", "#1b4f72"], bar: "#a3a3a3",
  mode: "#31a354", source: "#6a3d9a", target: "#ff7f00",
  progress: ["#352a87", "#1283d4", "#33b7a0", "#f9fb0e"],  // trajectories, start → end
};
const VIEW_3D = [-60, 25];  // azimuth, elevation of 3D frames (as zeromode.viz)
const SVG_NS = "http://www.w3.org/2000/svg";
const WIDTH = 640, HEIGHT = 480, PAD = 36;
// Requests beside the paper's named design examples (GET /v1/examples).
const PRESETS = {
  "auxetic sheet 3 × 3, ν = −0.5 (Fig. 5c–d)": {dim: 2, cells: [3, 3], poisson_ratio: -0.5},
  "allosteric source and target, 2D (Fig. 5e)": {
    dim: 2,
    source: {positions: [[0, 0], [1, 0], [0, 1]], motion: [[-1, 0], [1, 0], [0, 1]]},
    target: {positions: [[5, 0], [6, 0], [5, 1]], motion: [[0, -1], [1, 1], [-1, 0]]},
  },
};

const $ = (id) => document.getElementById(id);
const state = { response: null, frame: null, modes: [], mode: 0, motion: null, sites: {}, timer: null };

function headers() {
  const h = { "content-type": "application/json" };
  if ($("apikey").value) h["x-api-key"] = $("apikey").value;
  return h;
}

async function api(method, path, body) {
  const r = await fetch(path, { method, headers: headers(), body: body === undefined ? undefined : JSON.stringify(body) });
  if (!r.ok) {
    let message = `HTTP ${r.status}`;
    try { const d = (await r.json()).detail; message = `${d.code}: ${d.message}`; } catch (e) { /* not JSON */ }
    throw new Error(message);
  }
  return r;
}

function say(text, error = false) {
  $("status").textContent = text;
  $("status").className = error ? "error" : "";
}

function endpointOf(request) {
  if (request.source && request.target) return "/v1/design/allosteric";
  if ("cells" in request || "poisson_ratio" in request) return "/v1/design/auxetic";
  return "/v1/design";
}

// ----------------------------------------------------------------------------- geometry

function viewBasis([azimuth, elevation]) {
  const a = azimuth * Math.PI / 180, e = elevation * Math.PI / 180;
  const right = [-Math.sin(a), Math.cos(a), 0];
  const toward = [Math.cos(e) * Math.cos(a), Math.cos(e) * Math.sin(a), Math.sin(e)];
  const up = [toward[1] * right[2] - toward[2] * right[1], toward[2] * right[0] - toward[0] * right[2],
              toward[0] * right[1] - toward[1] * right[0]];
  return [right, up];
}

function projector(dim) {
  if (dim === 2) return (p) => [p[0], p[1]];
  const [r, u] = viewBasis(VIEW_3D);
  return (p) => [p[0] * r[0] + p[1] * r[1] + p[2] * r[2], p[0] * u[0] + p[1] * u[1] + p[2] * u[2]];
}

// One map from positions to the page for every configuration, so the frame moves on a still page.
function pageMap(configs, extra) {
  const project = projector(state.frame.dim);
  let lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
  for (const points of [...configs, extra]) {
    for (const p of points) {
      const s = project(p);
      lo = [Math.min(lo[0], s[0]), Math.min(lo[1], s[1])];
      hi = [Math.max(hi[0], s[0]), Math.max(hi[1], s[1])];
    }
  }
  const scale = Math.min((WIDTH - 2 * PAD) / ((hi[0] - lo[0]) || 1), (HEIGHT - 2 * PAD) / ((hi[1] - lo[1]) || 1));
  const ox = (WIDTH - (hi[0] - lo[0]) * scale) / 2, oy = (HEIGHT - (hi[1] - lo[1]) * scale) / 2;
  return (p) => { const s = project(p); return [ox + (s[0] - lo[0]) * scale, HEIGHT - oy - (s[1] - lo[1]) * scale]; };
}

function mix(colours, t) {
  const s = Math.min(Math.max(t, 0), 1) * (colours.length - 1), k = Math.min(Math.floor(s), colours.length - 2);
  const a = colours[k], b = colours[k + 1], f = s - k;
  const c = [1, 3, 5].map((i) => Math.round(parseInt(a.slice(i, i + 2), 16) * (1 - f) + parseInt(b.slice(i, i + 2), 16) * f));
  return "#" + c.map((v) => v.toString(16).padStart(2, "0")).join("");
}

// ----------------------------------------------------------------------------- drawing

// An SVG element (or, with html true, an HTML one) with attributes, appended to parent.
function el(tag, attrs, parent, html = false) {
  const node = html ? document.createElement(tag) : document.createElementNS(SVG_NS, tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (parent) parent.appendChild(node);
  return node;
}

function currentPositions() {
  const m = state.motion;
  return m ? m.path[Number($("slider").value)] : state.frame.positions;
}

function draw() {
  const svg = $("frame");
  svg.replaceChildren();
  if (!state.frame) return;
  const x = state.frame.positions, edges = state.frame.edges;
  const mode = state.modes[state.mode];
  const configs = state.motion ? state.motion.path : [x];
  // Arrows: the longest is a fifth of the frame's size.
  const size = Math.max(...[0, 1, 2].slice(0, state.frame.dim).map((a) => {
    const v = x.map((p) => p[a]); return Math.max(...v) - Math.min(...v);
  })) || 1;
  const longest = mode ? Math.max(...mode.map((u) => Math.hypot(...u))) || 1 : 1;
  const arrow = mode ? x.map((p, i) => p.map((v, a) => v + 0.2 * size * mode[i][a] / longest)) : x;
  const toPage = pageMap(configs, arrow);
  const defs = el("defs", {}, svg);
  const head = el("marker", { id: "head", viewBox: "0 0 10 10", refX: 8, refY: 5, markerWidth: 5, markerHeight: 5, orient: "auto-start-reverse" }, defs);
  el("path", { d: "M 0 0 L 10 5 L 0 10 z", fill: COLOURS.mode }, head);

  if (state.motion) {  // trajectories coloured by progress, behind the frame
    const g = el("g", { class: "trajectories" }, svg);
    const path = state.motion.path, steps = path.length - 1;
    for (let i = 0; i < x.length; i++) {
      for (let k = 0; k < steps; k++) {
        const [a, b] = [toPage(path[k][i]), toPage(path[k + 1][i])];
        el("line", { x1: a[0], y1: a[1], x2: b[0], y2: b[1], stroke: mix(COLOURS.progress, (k + 0.5) / steps), "stroke-width": 1.2 }, g);
      }
    }
  }
  const p = currentPositions().map(toPage);
  const bars = el("g", { class: "bars" }, svg);
  edges.forEach(([i, j], b) => el("line", {
    class: "bar", "data-edge": b, x1: p[i][0], y1: p[i][1], x2: p[j][0], y2: p[j][1],
    stroke: COLOURS.bar, "stroke-width": 2, "stroke-linecap": "round",
  }, bars));
  if (mode && !(state.motion && Number($("slider").value) !== state.motion.reference_index)) {
    const arrows = el("g", { class: "arrows" }, svg);
    x.forEach((_, i) => {
      const tip = toPage(arrow[i]);
      if (Math.hypot(tip[0] - p[i][0], tip[1] - p[i][1]) < 3) return;
      el("line", { class: "arrow", "data-node": i, x1: p[i][0], y1: p[i][1], x2: tip[0], y2: tip[1],
                   stroke: COLOURS.mode, "stroke-width": 2.2, "marker-end": "url(#head)" }, arrows);
    });
  }
  const spec = new Set(state.frame.specified);
  const nodes = el("g", { class: "nodes" }, svg);
  p.forEach((q, i) => {
    const [fill, line] = spec.has(i) ? COLOURS.specified : COLOURS.unspecified;
    el("circle", { class: "node " + (spec.has(i) ? "specified" : "unspecified"), "data-node": i, cx: q[0], cy: q[1], r: 5.5,
                   fill, stroke: line, "stroke-width": 1 }, nodes);
  });
  for (const [kind, colour] of [["source", COLOURS.source], ["target", COLOURS.target]]) {
    for (const i of state.sites[kind] || []) {
      const [cx, cy] = p[i], r = 9;
      const shape = kind === "source" ? `${cx - r},${cy - r} ${cx + r},${cy - r} ${cx + r},${cy + r} ${cx - r},${cy + r}`
                                      : `${cx},${cy - r * 1.3} ${cx + r * 1.3},${cy} ${cx},${cy + r * 1.3} ${cx - r * 1.3},${cy}`;
      el("polygon", { class: "marker " + kind, points: shape, fill: "none", stroke: colour, "stroke-width": 2 }, nodes);
    }
  }
  if (state.motion) {
    const k = Number($("slider").value);
    $("where").textContent = `t = ${state.motion.parameter[k].toFixed(3)} (${k + 1}/${state.motion.path.length})`;
  }
}

// ----------------------------------------------------------------------------- actions

async function loadExamples() {
  const select = $("example");
  const names = await (await api("GET", "/v1/examples")).json();
  for (const { name, description } of names) {
    el("option", { value: "example:" + name }, select, true).textContent = `${name} — ${description}`;
  }
  for (const label of Object.keys(PRESETS)) el("option", { value: "preset:" + label }, select, true).textContent = label;
}

async function pickExample() {
  const value = $("example").value;
  if (!value) return;
  const [kind, name] = [value.slice(0, value.indexOf(":")), value.slice(value.indexOf(":") + 1)];
  const request = kind === "preset" ? PRESETS[name]
    : await (await api("GET", `/v1/examples/${encodeURIComponent(name)}/request`)).json();
  $("request").value = JSON.stringify(request, null, 1);
}

async function design() {
  let request;
  try { request = JSON.parse($("request").value); } catch (e) { say("the request is not JSON: " + e.message, true); return; }
  const endpoint = endpointOf(request);
  say(`designing (${endpoint}) …`);
  stop();
  try {
    const response = await (await api("POST", endpoint, request)).json();
    state.response = response;
    state.frame = response.frame;
    state.modes = response.modes || [];
    state.mode = 0;
    const report = response.report || {};
    state.sites = { source: report.source || [], target: report.target || [] };
    state.motion = null;
    const modeSelect = $("mode");
    modeSelect.replaceChildren();
    state.modes.forEach((_, m) => { el("option", { value: m }, modeSelect, true).textContent = `mode ${m + 1}`; });
    modeSelect.disabled = state.modes.length < 2;
    showReport(response);
    draw();
    say(`designed: ${state.frame.positions.length} nodes, ${state.frame.edges.length} bars; tracing the finite motion …`);
    await traceMotion();
    await listDownloads();
  } catch (e) {
    say(e.message, true);
  }
}

function showReport(response) {
  const r = response.report || {}, a = r.analysis || {};
  const parts = [`${a.nodes} nodes`, `${a.edges} bars`, `${a.zero_modes} zero modes (${a.nontrivial_zero_modes} non-rigid)`,
                 `${a.self_stresses} self-stresses`];
  if ("poisson_ratio" in response) parts.push(`ν = ${response.poisson_ratio.toFixed(3)}`);
  if ("target_error" in r) parts.push(`target error ${r.target_error.toExponential(1)}`);
  $("summary").textContent = parts.join(" · ");
  $("report").textContent = JSON.stringify(r, null, 1);
}

async function traceMotion() {
  const body = { frame: state.frame, amplitude: 0.3, on_singularity: "report" };
  if (state.modes.length) body.mode = state.modes[state.mode];
  try {
    const motion = await (await api("POST", "/v1/motion", body)).json();
    state.motion = motion;
    const slider = $("slider");
    slider.max = motion.path.length - 1;
    slider.value = motion.reference_index;
    slider.disabled = false;
    $("play").disabled = false;
    say(`finite motion: ${motion.path.length} configurations, status ${motion.status}; drag the slider or press Play.`);
  } catch (e) {
    state.motion = null;
    $("slider").disabled = true;
    $("play").disabled = true;
    say("no finite motion: " + e.message, true);
  }
  draw();
}

function stop() {
  if (state.timer) clearInterval(state.timer);
  state.timer = null;
  $("play").textContent = "Play";
}

function play() {
  if (state.timer) { stop(); return; }
  const slider = $("slider");
  let direction = 1;
  $("play").textContent = "Pause";
  state.timer = setInterval(() => {
    let k = Number(slider.value) + direction;
    if (k > Number(slider.max) || k < 0) { direction = -direction; k += 2 * direction; }
    slider.value = k;
    draw();
  }, 50);
}

async function listDownloads() {
  const box = $("downloads");
  box.replaceChildren();
  const formats = await (await api("GET", "/v1/export/formats")).json();
  for (const f of formats.filter((f) => f.available)) {
    const button = el("button", { type: "button", "data-format": f.name, title: f.description }, box, true);
    button.textContent = `${f.name} (${f.suffix})`;
    button.addEventListener("click", () => download(f));
  }
}

async function download(format) {
  const body = { format: format.name, document: state.response, motion: { mode: state.mode } };
  if (state.motion) { body.path = state.motion.path; body.parameter = state.motion.parameter; }
  say(`exporting ${format.name} …`);
  try {
    const blob = await (await api("POST", "/v1/export", body)).blob();
    const link = document.createElement("a");
    link.href = URL.createObjectURL(blob);
    link.download = `zeromode${format.name === "cut_svg" ? "-cut" : ""}${format.suffix}`;
    document.body.appendChild(link);
    link.click();
    link.remove();
    setTimeout(() => URL.revokeObjectURL(link.href), 10000);
    say(`exported ${format.name} (${blob.size} bytes).`);
  } catch (e) {
    say(e.message, true);
  }
}

$("example").addEventListener("change", () => pickExample().catch((e) => say(e.message, true)));
$("design").addEventListener("click", design);
$("slider").addEventListener("input", draw);
$("play").addEventListener("click", play);
$("mode").addEventListener("change", async () => { stop(); state.mode = Number($("mode").value); await traceMotion(); });
loadExamples().catch((e) => say(e.message, true));
