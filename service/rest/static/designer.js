// zeromode designer: draw specified nodes and their motions, watch the solution space of an
// unspecified node (solution_space.js, computed here while you drag), design through the REST
// API, play the finite motion, refine and certify as jobs, read the report, take the files away.
// Plain JavaScript and SVG, no dependencies: the page talks to the service that serves it.
"use strict";

const SVG_NS = "http://www.w3.org/2000/svg";
const WIDTH = 800, HEIGHT = 600, PAD = 40;
// The drawing's window in world units (x from −3 to 3); positions snap to 1/8, motions to 1/16
// (binary fractions: a snapped drawing is exact, so symmetric targets stay exactly symmetric).
const WINDOW = { lo: [-3, -2.25], hi: [3, 2.25] };
const SNAP_POSITION = 1 / 8, SNAP_MOTION = 1 / 16;
// Crossings of two spaces closer than this fraction of the drawing's spread to a specified node
// are that node (every space passes through the specified nodes), not a place for a new one.
const CROSSING_GAP = 0.01;
// ε(a) above this is worth a word: the finite path visibly leaves the drawn arrows.
const DEPARTS = 0.05;
// The soliton's domain wall: a disc of this radius (px) on the chain where it is.
const WALL_RADIUS = 22;
const COLOURS = {
  specified: ["#d7301f", "#8c1d12"], unspecified: ["#2c7fb8", "#1b4f72"], bar: "#a3a3a3",
  source: "#6a3d9a", target: "#ff7f00", crossing: "#000000",
  motions: ["#31a354", "#e7298a", "#d95f02", "#7570b3"],   // arrows of motion 1, 2, …
  spaces: ["#2c7fb8", "#e6550d", "#8c6bb1", "#41ab5d"],    // their solution spaces
  progress: ["#352a87", "#1283d4", "#33b7a0", "#f9fb0e"],  // trajectories, start → end
};
const VIEW_3D = [-60, 25];  // azimuth, elevation of 3D frames (as zeromode.viz); drag to turn
const PRESETS = {
  auxetic_3x3: { kind: "auxetic", description: "Auxetic sheet, 3 × 3 modules, ν = −0.5 (Fig. 5c–d)." },
  allostery_2d: {
    kind: "allostery", description: "Allosteric source (left) drives a prescribed target motion (right) (Fig. 5e).",
    source: { positions: [[-2, 0], [-1.5, 0], [-2, 0.5]], motion: [[-0.25, 0], [0.25, 0], [0, 0.25]] },
    target: { positions: [[1.5, 0], [2, 0], [1.5, 0.5]], motion: [[0, -0.25], [0.25, 0.25], [-0.25, 0]] },
  },
};
// The 3D tab's first target: five specified nodes, one motion (the example five_node_3d): the
// space of a node joined to all five is a curve in a plane.
const DEFAULT_3D = {
  positions: [[2, 0, 1], [1, 0, 2], [3, 0, 3], [3.5, -1, 2.5], [3.5, 1, 2.5]],
  motion: [[-0.8, 0, 0.8], [0.8, 0, -0.8], [-0.8, 0, 0], [0, -0.8, 0], [0, 0.8, 0]],
};
// A click that moves the pointer less than this (px) places a node in 3D; more turns the view.
const CLICK_SLOP = 4;
// A click farther than this (px) from every drawn space places nothing.
const PICK_RADIUS = 20;
// The drawn network of the Allostery tab: a triangulated sheet, NETWORK columns × rows, rigid.
const NETWORK = [9, 7], NETWORK_SPACING = 0.5;
// Human names of the export formats (GET /v1/export/formats); the service's description is the tooltip.
const FORMAT_LABELS = {
  vtk: "ParaView (.vtu)", xdmf: "ParaView motion (.xdmf)", node_link_json: "Graph, JSON", graphml: "GraphML",
  kit_csv: "Build kit, CSV", dxf: "Cut file, DXF", cut_svg: "Cutting plan, SVG", stl: "3D print (.stl)",
  svg_animation: "Animation, SVG", gif: "Animation, GIF", mp4: "Animation, MP4",
  map_csv: "Module map, CSV", map_svg: "Module map, SVG", map_png: "Module map, PNG",
};

const $ = (id) => document.getElementById(id);
const state = {
  kind: "draw", network: null, layers: {}, sketches: {}, options: {}, designs: 0, pending: false, running: new Set(), waiting: new Set(), nodes: [], motions: [[]], motion: 0, placed: [], spaces: [], crossings: [],
  example: null, response: null, frame: null, modes: [], mode: 0, sites: {}, motionPath: null,
  refined: null, refinedPath: null, certificate: null, timer: null, drag: null, view: VIEW_3D.slice(),
  formats: null, jobs: 0, timings: { live: [], design: [], table: [], turn: [] }, progressLog: [], map: null, appearAt: -Infinity,
  conformations: [], features: [], chainExamples: null, jobEndpoints: [], mapCheck: null, module: null,
};
window.designer = state;  // for outside tests and the curious

// ----------------------------------------------------------------------------- service

function headers() {
  const h = { "content-type": "application/json" };
  if ($("apikey").value) h["x-api-key"] = $("apikey").value;
  return h;
}

// A direct request (no job: a 2D design, a motion, an export, allostery in a network) still
// unanswered after this long shows the bar as busy until it is answered: the service's
// synchronous endpoints report no fraction, but a GIF can take ten seconds.
const BUSY_MS = 1000;

async function api(method, path, body) {
  const busy = setTimeout(() => showBusy(`${method} ${path}`), BUSY_MS);
  try {
    return await request(method, path, body);
  } finally {
    clearTimeout(busy);
    hideBusy(`${method} ${path}`);
  }
}

function showBusy(what) {
  const bar = document.querySelector("[data-testid=progress]");
  if (!$("progress-box").hidden && !bar.classList.contains("busy")) return;  // a job's progress is showing
  state.waiting.add(what);
  bar.classList.add("busy");
  $("progress-box").hidden = false;
  $("progress-text").textContent = `waiting for ${[...state.waiting].join(", ")} …`;
}

function hideBusy(what) {
  if (!state.waiting.delete(what) || state.waiting.size) return;
  document.querySelector("[data-testid=progress]").classList.remove("busy");
  $("progress-box").hidden = true;
}

async function request(method, path, body) {
  const r = await fetch(path, { method, headers: headers(), body: body === undefined ? undefined : JSON.stringify(body) });
  if (!r.ok) {
    let message = `HTTP ${r.status}`;
    try {
      const detail = (await r.json()).detail;
      message = Array.isArray(detail) ? detail.map((e) => `${e.loc.join(".")}: ${e.msg}`).join("; ") : `${detail.code}: ${detail.message}`;
    } catch (e) { /* not JSON */ }
    if (r.status === 401) {  // the service asks for a key: where to give it
      $("apikey").closest("details").open = true;
      message += " Enter the API key under Service.";
    }
    throw new Error(message);
  }
  return r;
}
const post = async (path, body) => (await api("POST", path, body)).json();
const sleep = (ms) => new Promise((done) => setTimeout(done, ms));

// A long request as a job (POST /v1/jobs), its progress on the bar until it is done; once
// ``wanted()`` is false (its design was replaced or cleared) the job is cancelled and null returned.
async function runJob(endpoint, request, label, wanted) {
  const seq = ++state.jobs;
  const accepted = await post("/v1/jobs", { endpoint, request });
  showProgress(0, `${label}: queued`);
  try {
    for (;;) {
      await sleep(200);
      if (!wanted()) {
        api("DELETE", `/v1/jobs/${accepted.id}`).catch(() => {});  // finished meanwhile: nothing to cancel
        return null;
      }
      const job = await (await api("GET", `/v1/jobs/${accepted.id}`)).json();
      showProgress(job.progress, `${label}: ${job.message || job.status}`);
      if (job.status === "done") return job.result;
      if (["failed", "cancelled", "interrupted"].includes(job.status)) {
        throw new Error(job.error ? `${job.error.code}: ${job.error.message}` : `the job was ${job.status}.`);
      }
    }
  } finally {
    setTimeout(() => { if (state.jobs === seq && !state.waiting.size) $("progress-box").hidden = true; }, 600);
  }
}

function showProgress(fraction, text) {
  const bar = document.querySelector("[data-testid=progress]");
  $("progress-box").hidden = false;
  bar.classList.remove("busy");
  state.waiting.clear();
  bar.firstElementChild.style.width = `${(100 * fraction).toFixed(1)}%`;
  bar.dataset.value = String(fraction);
  bar.setAttribute("aria-valuenow", String(fraction));
  $("progress-text").textContent = text;
  state.progressLog.push(fraction);
}

function say(text, error = false) {
  $("status").textContent = text;
  $("status").className = error ? "error" : "";
}

// ----------------------------------------------------------------------------- geometry

function viewBasis([azimuth, elevation]) {
  const a = azimuth * Math.PI / 180, e = elevation * Math.PI / 180;
  const right = [-Math.sin(a), Math.cos(a), 0];
  const toward = [Math.cos(e) * Math.cos(a), Math.cos(e) * Math.sin(a), Math.sin(e)];
  const up = [toward[1] * right[2] - toward[2] * right[1], toward[2] * right[0] - toward[0] * right[2],
              toward[0] * right[1] - toward[1] * right[0]];
  return [right, up, toward];  // toward: from the drawing to the viewer
}

function projector(dim) {
  if (dim !== 3) return (p) => [p[0], p[1]];
  const [r, u] = viewBasis(state.view);
  return (p) => [p[0] * r[0] + p[1] * r[1] + p[2] * r[2], p[0] * u[0] + p[1] * u[1] + p[2] * u[2]];
}

// One map from world to page for everything drawn: the drawing's window, grown (never shrunk)
// to hold the frame along its whole motion, so a design drawn in the window stays in place.
function makeMap() {
  const dim = state.frame ? state.frame.dim : sketchDim(), project = projector(dim);
  // Conformations and chains are typed, not drawn: their drawing fits them.
  const fit = dim === 3 || state.kind === "multistable" || state.kind === "chain";
  let lo = fit ? [Infinity, Infinity] : WINDOW.lo.slice(), hi = fit ? [-Infinity, -Infinity] : WINDOW.hi.slice();
  const tips = state.nodes.map((n, i) => n.x.map((v, a) => v + (state.motions[0][i] || [0, 0, 0])[a]));
  // A surface's box is part of the 3D drawing, before and after a design.
  const boxes = dim === 3 ? state.spaces.filter((s) => s.box).map(boxCorners) : [];
  const configs = state.frame ? [...(state.motionPath ? state.motionPath.path : [state.frame.positions]), ...boxes]
    : dim === 3 ? [state.nodes.map((n) => n.x), tips, ...boxes]
    : state.kind === "multistable" ? state.conformations
    : state.network ? [state.network.positions] : [];
  for (const points of configs) for (const p of points) {
    const s = project(p);
    lo = [Math.min(lo[0], s[0]), Math.min(lo[1], s[1])];
    hi = [Math.max(hi[0], s[0]), Math.max(hi[1], s[1])];
  }
  if (!Number.isFinite(lo[0])) { lo = WINDOW.lo.slice(); hi = WINDOW.hi.slice(); }
  const inWindow = !fit && lo[0] >= WINDOW.lo[0] && hi[0] <= WINDOW.hi[0] && lo[1] >= WINDOW.lo[1] && hi[1] <= WINDOW.hi[1];
  const pad = inWindow ? 0 : PAD;
  const scale = Math.min((WIDTH - 2 * pad) / ((hi[0] - lo[0]) || 1), (HEIGHT - 2 * pad) / ((hi[1] - lo[1]) || 1));
  const ox = (WIDTH - (hi[0] - lo[0]) * scale) / 2, oy = (HEIGHT - (hi[1] - lo[1]) * scale) / 2;
  const toPage = (p) => { const s = project(p); return [ox + (s[0] - lo[0]) * scale, HEIGHT - oy - (s[1] - lo[1]) * scale]; };
  const toWorld = ([px, py]) => [lo[0] + (px - ox) / scale, lo[1] + (HEIGHT - oy - py) / scale];
  return { toPage, toWorld, scale };
}

function mix(colours, t) {
  const s = Math.min(Math.max(t, 0), 1) * (colours.length - 1), k = Math.min(Math.floor(s), colours.length - 2);
  const a = colours[k], b = colours[k + 1], f = s - k;
  const c = [1, 3, 5].map((i) => Math.round(parseInt(a.slice(i, i + 2), 16) * (1 - f) + parseInt(b.slice(i, i + 2), 16) * f));
  return "#" + c.map((v) => v.toString(16).padStart(2, "0")).join("");
}

const snap = (v, step) => ($("snap").checked ? Math.round(v / step) * step : v);
const fmt = (v, digits = 3) => (v === null || v === undefined ? "—" : typeof v !== "number" ? String(v)
  : v !== 0 && (Math.abs(v) < 1e-3 || Math.abs(v) >= 1e5) ? v.toExponential(2) : Number(v.toFixed(digits)).toString());

// ----------------------------------------------------------------------------- the drawing

const specifiedNodes = () => state.nodes.filter((n) => n.role === "specified");
// The drawing (or the 3D table) is the target, and its solution space is shown.
const sketching = () => (state.kind === "draw" || state.kind === "space3d") && !state.example;
const sketchDim = () => (state.kind === "space3d" ? 3 : 2);

// Solution spaces of the drawn motions (one per motion) and where they cross (Fig. 4).
function updateSpaces() {
  state.spaces = [];
  state.crossings = [];
  const spec = state.nodes.map((n, i) => [n, i]).filter(([n]) => n.role === "specified");
  if (!sketching() || !spec.length) return;
  const x = spec.map(([n]) => n.x);
  const spread = Math.max(...[0, 1].map((a) => Math.max(...x.map((p) => p[a])) - Math.min(...x.map((p) => p[a])))) || 1;
  state.spaces = state.motions.map((motion) => SolutionSpace.compute(x, spec.map(([, i]) => motion[i])));
  for (let a = 0; a < state.spaces.length && x[0].length === 2; a++) {
    for (let b = a + 1; b < state.spaces.length; b++) {
      // Every space passes through the specified nodes themselves: those crossings are no place for a node.
      state.crossings.push(...SolutionSpace.intersections(state.spaces[a].curves, state.spaces[b].curves)
        .filter((p) => x.every((q) => Math.hypot(p[0] - q[0], p[1] - q[1]) > CROSSING_GAP * spread)));
    }
  }
}

function describeSpaces() {
  const box = $("space-text");
  box.className = "space";
  if (!sketching()) { box.textContent = ""; return; }
  if (!state.spaces.length) { box.textContent = "The solution space of an unspecified node appears once you place specified nodes."; return; }
  const still = (m) => state.nodes.every((n, i) => n.role !== "specified" || !(state.motions[m][i] || []).some((v) => v));
  const words = state.spaces.map((s, m) => {
    const tag = state.spaces.length > 1 ? `motion ${m + 1}: ` : "";
    if (still(m)) return `${tag}no arrows yet: drag from a node to give it a motion.`;
    if (s.kind === "none") return `${tag}no real solution — ${s.reason}`;
    if (s.kind === "points") return `${tag}${s.points.length} point${s.points.length === 1 ? "" : "s"} (m = ${s.nullity}); click one to place an unspecified node.`;
    if (s.kind === "conic" && s.dim === 3) return `${tag}a curve (m = ${s.nullity}), a conic in a plane of space (Fig. 2e); click on it to place an unspecified node.`;
    if (s.kind === "quadric") {
      const why = { "a pair of crossing planes": " (degenerate: the quadric factors into two planes)", "a cone": " (degenerate: a cone, singular at its apex)",
                    "a plane": " (degenerate: the specified nodes are coplanar, so every solution's position lies in one plane)" }[s.shape] || "";
      if (!s.curves.length) return `${tag}a surface (m = ${s.nullity}): ${s.shape}${why}; ${s.reason}`;
      return `${tag}a surface (m = ${s.nullity}): ${s.shape}${why}, drawn as its plane sections inside a box around the nodes (Fig. 2g); click on it to place an unspecified node.`;
    }
    if (s.kind === "conic") return `${tag}a ${s.degenerate ? "degenerate " : ""}conic (m = ${s.nullity}); click on it to place an unspecified node.`;
    if (s.kind === "line") return `${tag}a line of positions (m = ${s.nullity}).`;
    return `${tag}${s.reason}`;
  });
  if (state.spaces.length > 1) words.push(`${state.crossings.length} crossing${state.crossings.length === 1 ? "" : "s"}: a node there moves with every motion.`);
  box.textContent = words.join(" ");
  if (state.spaces.every((s) => s.kind === "none")) box.className = "space none";
}

// The eight corners of a surface's box (world), in the order of the bits x, y, z.
const boxCorners = (space) => [0, 1, 2, 3, 4, 5, 6, 7].map((c) => [0, 1, 2].map((a) => space.box[(c >> a) & 1][a]));

// The parts of a surface's curves nearer the viewer than its box's centre: drawn over the whole
// wireframe so that the front of the surface reads in front of its back.
function frontCurves(space) {
  const toward = viewBasis(state.view)[2];
  const depth = (p) => p.reduce((t, v, a) => t + (v - (space.box[0][a] + space.box[1][a]) / 2) * toward[a], 0);
  const parts = [];
  for (const c of space.curves) {
    let run = [];
    for (const p of c) {
      if (depth(p) >= 0) { run.push(p); continue; }
      if (run.length > 1) parts.push(run);
      run = [];
    }
    if (run.length > 1) parts.push(run);
  }
  return parts;
}

// The SVG path of a space: polylines for curves, small circles for points.
function spacePath(space, toPage) {
  const parts = space.curves.map((c) => c.map((p, i) => { const q = toPage(p); return `${i ? "L" : "M"}${q[0].toFixed(2)} ${q[1].toFixed(2)}`; }).join(""));
  for (const { position } of space.points) {
    const [x, y] = toPage(position);
    parts.push(`M${(x - 6).toFixed(2)} ${y.toFixed(2)}a6 6 0 1 0 12 0a6 6 0 1 0 -12 0`);
  }
  return parts.join("");
}

// ----------------------------------------------------------------------------- drawing

function el(tag, attrs, parent, html = false) {
  const node = html ? document.createElement(tag) : document.createElementNS(SVG_NS, tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (parent) parent.appendChild(node);
  return node;
}

function arrowHeads(defs, colours) {
  colours.forEach((colour, m) => {
    const head = el("marker", { id: `head-${m}`, viewBox: "0 0 10 10", refX: 8, refY: 5, markerWidth: 5, markerHeight: 5, orient: "auto-start-reverse" }, defs);
    el("path", { d: "M 0 0 L 10 5 L 0 10 z", fill: colour }, head);
  });
}

function currentPositions() {
  const m = state.motionPath;
  return m ? m.path[Number($("slider").value)] : state.frame.positions;
}

function draw() {
  const svg = $("canvas");
  svg.replaceChildren();
  state.map = makeMap();
  const { toPage } = state.map;
  const defs = el("defs", {}, svg);
  arrowHeads(defs, COLOURS.motions);
  const shown = new Set();
  if (!state.frame && !state.nodes.length && !state.example && !state.network && !(state.kind === "multistable" && state.conformations.length)) {
    // 22 units: 12 px when the drawing is at its narrowest (800 px windows).
    const t = el("text", { x: WIDTH / 2, y: HEIGHT / 2, "text-anchor": "middle", fill: "#999", "font-size": 22 }, svg);
    t.textContent = state.kind === "auxetic" ? "Set the sheet on the left, then press Design."
      : state.kind === "chain" ? "Choose the map's features on the left, then press Design."
      : state.kind === "multistable" ? "Type the conformations on the left, then press Design."
      : state.kind === "allostery" ? "Click to place a source node (or pick sites in a network); drag from it to set its motion."
      : "Click to place a node; drag from it to set its motion.";
  }
  drawSpaces(svg, toPage, shown);
  if (state.frame) drawFrame(svg, toPage, shown);
  else if (state.kind === "multistable") drawConformations(svg, toPage, shown);
  else drawSketch(svg, toPage, shown);
  legend(shown);
  drawCharts();
}

// Before a multistable design: the conformations of the form, each in its colour, the nodes of
// one joined in order (dashed).
function drawConformations(svg, toPage, shown) {
  const g = el("g", { class: "conformations" }, svg);
  state.conformations.forEach((points, c) => {
    const colour = CONFORMATION_COLOURS[c % 3], p = points.map(toPage);
    el("polygon", { points: p.map((q) => q.join(",")).join(" "), fill: "none", stroke: colour, "stroke-dasharray": "5 4", "stroke-width": 1.5 }, g);
    p.forEach(([x, y], i) => el("circle", { class: "conformation-node", "data-conformation": c, "data-node": i, cx: x, cy: y, r: 6,
                                            fill: c ? "#fff" : COLOURS.specified[0], stroke: colour, "stroke-width": 2 }, g));
    shown.add(`conformation-${c}`);
  });
}

// The charts under the drawing, at the slider's sample: the energy landscape of a multistable
// design; the module's map with the chain's cobweb, and d_k along the chain (for a soliton, with
// its wall, and the springs' energy along the drive).
function drawCharts() {
  const r = state.response, m = state.motionPath, k = m ? Number($("slider").value) : null;
  const soliton = Boolean(m && m.own === "soliton");
  $("landscape-box").hidden = !(r && (r.landscape || soliton) && k !== null);
  $("map-box").hidden = !(r && r.map);
  if (r && r.landscape && k !== null) drawLandscape($("landscape"), r, k);
  if (soliton) drawDriveEnergy($("landscape"), m, k);
  caption("landscape-caption", soliton, "Energy of the springs along the drive: zero in both uniform states (dashed), the drawing's position (blue)");
  caption("profile-caption", soliton, "d_k along the chain, the wall where the switched fraction crosses ½ (purple)");
  if (r && r.map) {
    const d = r.chain && k !== null ? r.chain.distances[m.rows ? m.rows[k] : k] : null;
    drawMapChart($("map-chart"), r.map, d);
    $("profile").parentNode.hidden = !d;
    $("map-caption").textContent = d ? "the module's map f, the chain as a cobweb" : "the module's map f, its fixed points and folds";
    if (d) drawProfile($("profile"), r.map, d, soliton ? { wall: m.wall[k], d_u: r.soliton.unstable.d, d_s: r.soliton.stable.d } : undefined);
  }
}

// A chart's caption: ``text`` for a soliton, else the page's own.
function caption(id, soliton, text) {
  const c = $(id);
  if (c.dataset.plain === undefined) c.dataset.plain = c.textContent;
  c.textContent = soliton ? text : c.dataset.plain;
}

function drawSpaces(svg, toPage, shown) {
  if (!state.spaces.length) return;
  const g = el("g", { class: "spaces" }, svg);
  state.spaces.forEach((space, m) => {
    const colour = COLOURS.spaces[m % COLOURS.spaces.length];
    const d = spacePath(space, toPage);
    const attrs = {
      class: `space ${space.kind}`, "data-testid": m ? `solution-space-${m + 1}` : "solution-space", "data-kind": space.kind,
      "data-motion": m, d, stroke: colour, "stroke-width": 2.2, fill: space.kind === "points" ? colour : "none",
      "fill-opacity": 0.25, "pointer-events": "none",
    };
    // A surface: a wireframe of conic sections in its box, its back faint and its front stronger.
    if (space.kind === "quadric") {
      Object.assign(attrs, { "data-shape": space.shape, "stroke-width": 1, "stroke-opacity": 0.35, "stroke-linejoin": "round" });
      const corners = boxCorners(space).map(toPage), box = [];
      for (let c = 0; c < 8; c++) for (const a of [1, 2, 4]) if (!(c & a)) box.push(`M${corners[c].join(" ")}L${corners[c | a].join(" ")}`);
      el("path", { class: "space-box", d: box.join(""), stroke: "#bdbdbd", "stroke-width": 1, "stroke-dasharray": "3 3", fill: "none", "pointer-events": "none" }, g);
    }
    el("path", attrs, g);
    if (space.kind === "quadric") {
      el("path", { class: "space front", d: spacePath({ curves: frontCurves(space), points: [] }, toPage), stroke: colour,
                   "stroke-width": 1.4, "stroke-opacity": 0.85, fill: "none", "pointer-events": "none" }, g);
    }
    if (space.curves.length || space.points.length) shown.add(`space-${m}`);
  });
  for (const [i, p] of state.crossings.entries()) {
    const [x, y] = toPage(p);
    el("circle", { class: "crossing", "data-crossing": i, cx: x, cy: y, r: 7, fill: "none", stroke: COLOURS.crossing, "stroke-width": 2 }, g);
    shown.add("crossing");
  }
}

// Before a design: the drawn nodes, their arrows (every motion) and nodes placed by hand.
function drawSketch(svg, toPage, shown) {
  const spec = state.nodes.map((n, i) => [n, i]).filter(([n]) => n.role === "specified");
  const bars = el("g", { class: "bars" }, svg);
  if (state.network) {
    bars.appendChild(networkLayer(toPage));
    shown.add("bar"); shown.add("unspecified");
  }
  for (const node of state.placed) {
    for (const [n] of spec) {
      const [a, b] = [toPage(node.x), toPage(n.x)];
      el("line", { class: "bar", x1: a[0], y1: a[1], x2: b[0], y2: b[1], stroke: COLOURS.bar, "stroke-width": 2 }, bars);
      shown.add("bar");
    }
  }
  const arrows = el("g", { class: "arrows" }, svg);
  state.motions.forEach((motion, m) => {
    state.nodes.forEach((n, i) => {
      const u = motion[i];
      if (!u || Math.hypot(...u) === 0) return;
      const [a, b] = [toPage(n.x), toPage(n.x.map((v, c) => v + u[c]))];
      el("line", { class: "arrow drawn", "data-node": i, "data-motion": m, x1: a[0], y1: a[1], x2: b[0], y2: b[1],
                   stroke: COLOURS.motions[m % 4], "stroke-width": 2.5, opacity: m === state.motion ? 1 : 0.45,
                   "marker-end": `url(#head-${m % 4})` }, arrows);
      shown.add(`motion-${m}`);
    });
  });
  const nodes = el("g", { class: "nodes" }, svg);
  state.nodes.forEach((n, i) => {
    const [x, y] = toPage(n.x);
    const [fill, line] = n.role === "specified" ? COLOURS.specified : COLOURS.unspecified;
    if (n.role === "specified") {
      el("circle", { class: "node drawn specified", "data-drawn": i, cx: x, cy: y, r: 7, fill, stroke: line, "stroke-width": 1 }, nodes);
      shown.add("specified");
    } else {
      marker(nodes, n.role, x, y);
      shown.add(n.role);
      el("circle", { class: "node drawn", "data-drawn": i, cx: x, cy: y, r: 6, fill: "#fff", stroke: COLOURS[n.role], "stroke-width": 2 }, nodes);
    }
  });
  for (const node of state.placed) {
    const [x, y] = toPage(node.x);
    if (node.u) {  // 3D: its motion from the linear system
      const tip = toPage(node.x.map((v, c) => v + node.u[c]));
      el("line", { class: "arrow placed", x1: x, y1: y, x2: tip[0], y2: tip[1], stroke: COLOURS.motions[0], "stroke-width": 2,
                   opacity: 0.7, "marker-end": "url(#head-0)" }, arrows);
    }
    el("circle", { class: "node placed unspecified", cx: x, cy: y, r: 6, fill: COLOURS.unspecified[0], stroke: COLOURS.unspecified[1] }, nodes);
    shown.add("unspecified");
  }
}

// A layer that does not move with the slider or the pointer (a given network, the trajectories),
// rebuilt only when what it shows (``source``) or the drawing's map or view changes: a redraw at
// every pointer move or animation frame re-attaches it instead of rebuilding thousands of elements.
function cachedLayer(slot, source, build) {
  const key = `${state.map.scale} ${state.map.toPage([0, 0, 0])} ${state.view}`, cached = state.layers[slot];
  if (cached && cached.source === source && cached.key === key) return cached.g;
  state.layers[slot] = { source, key, g: build() };
  return state.layers[slot].g;
}

const pageXY = (q) => `${q[0].toFixed(1)} ${q[1].toFixed(1)}`;

// The given network: its bars as one path, its nodes to click.
function networkLayer(toPage) {
  return cachedLayer("network", state.network, () => {
    const g = el("g", { class: "network" }), p = state.network.positions.map(toPage);
    el("path", { class: "bar network", "data-bars": state.network.edges.length, d: state.network.edges.map(([i, j]) => `M${pageXY(p[i])}L${pageXY(p[j])}`).join(""),
                 stroke: COLOURS.bar, "stroke-width": 1.5, fill: "none" }, g);
    p.forEach(([x, y], i) => el("circle", { class: "network-node", "data-network": i, cx: x, cy: y, r: 6,
                                            fill: COLOURS.unspecified[0], stroke: COLOURS.unspecified[1] }, g));
    return g;
  });
}

// The nodes' trajectories along the traced motion: one light polyline per node for a long path
// (multistable, chain); else step k of every node in one path of step k's colour (start → end).
function trajectoryLayer(toPage, n) {
  return cachedLayer("trajectories", state.motionPath, () => {
    const g = el("g", { class: "trajectories" }), path = state.motionPath.path;
    if (state.motionPath.own) {
      for (let i = 0; i < n; i++) {
        el("polyline", { points: path.map((c) => toPage(c[i]).map((v) => v.toFixed(1)).join(",")).join(" "), fill: "none", stroke: "#c6dbef", "stroke-width": 1.2 }, g);
      }
      return g;
    }
    const pages = path.map((c) => c.map(toPage)), steps = path.length - 1;
    for (let k = 0; k < steps; k++) {
      el("path", { class: "step", "data-step": k, d: pages[k].map((a, i) => `M${pageXY(a)}L${pageXY(pages[k + 1][i])}`).join(""),
                   fill: "none", stroke: mix(COLOURS.progress, (k + 0.5) / steps), "stroke-width": 1.2 }, g);
    }
    return g;
  });
}

// Judicious placement adds the unspecified nodes one round after another (in index order): each
// appears APPEAR_STEP after the one before (the whole at most APPEAR_TOTAL), its bars with it. The
// delays count from the design's arrival, so a redraw meanwhile (the motion traced, the slider)
// carries the animation on instead of restarting or cutting it. appear(i): node i's CSS animation
// delay in s (negative: under way), null for a specified node or once it has appeared.
const APPEAR_STEP = 0.15, APPEAR_TOTAL = 2, APPEAR_S = 0.3;
function appearance(n, specified) {
  const order = new Map(), elapsed = (performance.now() - state.appearAt) / 1000;
  for (let i = 0; i < n; i++) if (!specified.has(i)) order.set(i, order.size);
  const step = Math.min(APPEAR_STEP, APPEAR_TOTAL / Math.max(order.size, 1));
  return (i) => {
    if (!order.has(i)) return null;
    const delay = step * order.get(i) - elapsed;
    return delay + APPEAR_S > 0 ? delay : null;
  };
}

function marker(parent, kind, cx, cy) {
  const r = 10;
  const shape = kind === "source" ? `${cx - r},${cy - r} ${cx + r},${cy - r} ${cx + r},${cy + r} ${cx - r},${cy + r}`
    : `${cx},${cy - r * 1.3} ${cx + r * 1.3},${cy} ${cx},${cy + r * 1.3} ${cx - r * 1.3},${cy}`;
  el("polygon", { class: "marker " + kind, points: shape, fill: "none", stroke: COLOURS[kind], "stroke-width": 2 }, parent);
}

// After a design: the frame at the slider's configuration, its trajectories and its mode.
function drawFrame(svg, toPage, shown) {
  const x = state.frame.positions, edges = state.frame.edges;
  const mode = state.modes[state.mode];
  const own = state.motionPath && state.motionPath.own;
  if (state.motionPath && own !== "soliton") {  // not a soliton's: its chain is the picture
    svg.appendChild(trajectoryLayer(toPage, x.length));
    shown.add(own ? "track" : "path");
  }
  const p = currentPositions().map(toPage);
  const r = state.response;
  if (r.landscape) {
    // Where the designed minima are: the specified nodes at each conformation's sample.
    const g = el("g", { class: "conformations" }, svg);
    r.landscape.conformation_samples.forEach((sample, c) => {
      for (const i of state.frame.specified) {
        const [cx, cy] = toPage(r.landscape.positions[sample][i]);
        el("circle", { class: "conformation", "data-conformation": c, cx, cy, r: 10, fill: "none", stroke: CONFORMATION_COLOURS[c % 3], "stroke-width": 2 }, g);
      }
      shown.add(`conformation-${c}`);
    });
  }
  const soliton = own === "soliton" ? state.motionPath : null, k = soliton && Number($("slider").value);
  if (soliton && soliton.point[k]) {
    // The domain wall behind the chain, at the body's point where the switched fraction is ½.
    const [cx, cy] = toPage(soliton.point[k]);
    el("circle", { class: "wall", "data-testid": "wall", "data-wall": soliton.wall[k], cx, cy, r: WALL_RADIUS,
                   fill: CHART.wall, "fill-opacity": 0.25, stroke: CHART.wall, "stroke-width": 2 }, svg);
    shown.add("wall");
  }
  const springs = r.springs || (r.soliton && r.soliton.springs);
  if (springs) {
    const g = el("g", { class: "springs" }, svg);
    springs.pairs.forEach(([i, j], s) => el("path", { class: "spring", "data-spring": s, d: springPath(p[i], p[j]), fill: "none",
                                                          stroke: CHART.spring, "stroke-width": 1, opacity: 0.6 }, g));
    shown.add("spring");
  }
  const bars = el("g", { class: "bars" }, svg), appear = appearance(x.length, new Set(state.frame.specified));
  edges.forEach(([i, j], b) => {
    const attrs = { class: "bar", "data-edge": b, x1: p[i][0], y1: p[i][1], x2: p[j][0], y2: p[j][1],
                    stroke: COLOURS.bar, "stroke-width": springs ? 3 : 2, "stroke-linecap": "round" };
    const delay = Math.max(appear(i) ?? -Infinity, appear(j) ?? -Infinity);  // a bar comes with its newer node
    if (delay > -Infinity) Object.assign(attrs, { class: "bar bar-new", style: `animation-delay: ${delay.toFixed(3)}s` });
    el("line", attrs, bars);
  });
  shown.add(springs ? "rod" : "bar");
  const pairs = r.chain ? r.chain.pairs : r.module ? [r.module.input_pair, r.module.output_pair] : null;
  if (pairs) {
    const g = el("g", { class: "pairs" }, svg);
    pairs.forEach(([i, j], k) => el("line", { class: "pair", "data-pair": k, x1: p[i][0], y1: p[i][1], x2: p[j][0], y2: p[j][1],
                                                     stroke: CHART.pair, "stroke-width": 1.5, "stroke-dasharray": "4 3" }, g));
    shown.add("pair");
    if (soliton) {
      // The driven input pair (held, as the paper draws it): the wall walks away from it.
      const [i, j] = pairs[0];
      el("line", { class: "input-pair", x1: p[i][0], y1: p[i][1], x2: p[j][0], y2: p[j][1], stroke: "#000", "stroke-width": 4, "stroke-linecap": "round" }, g);
      shown.add("input-pair");
    }
  }
  const atReference = !state.motionPath || Number($("slider").value) === state.motionPath.reference_index;
  if (mode && atReference) {
    const size = Math.max(...[0, 1, 2].slice(0, state.frame.dim).map((a) => {
      const v = x.map((q) => q[a]); return Math.max(...v) - Math.min(...v);
    })) || 1;
    const longest = Math.max(...mode.map((u) => Math.hypot(...u))) || 1;
    const spec = new Set(state.frame.specified);
    // Arrows at the drawing's own length where the user drew them; else the longest a fifth of the frame.
    const drawnScale = state.fromDrawing ? 1 : 0.2 * size / longest;
    const arrows = el("g", { class: "arrows" }, svg);
    x.forEach((q, i) => {
      const tip = toPage(q.map((v, a) => v + drawnScale * mode[i][a]));
      if (Math.hypot(tip[0] - p[i][0], tip[1] - p[i][1]) < 3) return;
      el("line", { class: "arrow", "data-node": i, x1: p[i][0], y1: p[i][1], x2: tip[0], y2: tip[1],
                   stroke: COLOURS.motions[0], "stroke-width": 2.2, opacity: spec.has(i) ? 1 : 0.8, "marker-end": "url(#head-0)" }, arrows);
    });
  }
  // In the legend all along the motion (the arrows are drawn at its start): no jump while playing.
  if (mode) shown.add("mode");
  const spec = new Set(state.frame.specified);
  const nodes = el("g", { class: "nodes" }, svg);
  p.forEach((q, i) => {
    const isSpec = spec.has(i);
    const [fill, line] = isSpec ? COLOURS.specified : COLOURS.unspecified;
    const attrs = { class: "node " + (isSpec ? "specified" : "unspecified"), "data-node": i, cx: q[0], cy: q[1], r: soliton ? 3.5 : 5.5, fill, stroke: line, "stroke-width": 1 };
    if (appear(i) !== null) { attrs.class += " node-new"; attrs.style = `animation-delay: ${appear(i).toFixed(3)}s`; }
    el("circle", attrs, nodes);
    shown.add(isSpec ? "specified" : "unspecified");
  });
  for (const kind of ["source", "target"]) {
    for (const i of state.sites[kind] || []) { marker(nodes, kind, p[i][0], p[i][1]); shown.add(kind); }
  }
  if (state.motionPath) {
    const k = Number($("slider").value), m = state.motionPath;
    const signed = (v) => `${v >= 0 ? "+" : "−"}${Math.abs(v).toFixed(3)}`;
    $("where").textContent = m.own === "landscape" ? `s ${m.parameter[k].toFixed(3)} · E ${fmt(r.landscape.energy[k], 3)}`
      : m.own === "soliton" ? (m.wall[k] === null ? "wall off the chain" : `wall at ${m.wall[k].toFixed(2)} of ${r.soliton.springs.pairs.length}`)
      : m.own === "chain" ? `d₀ ${m.parameter[k].toFixed(3)} · d_n ${r.chain.distances[k][r.chain.distances[k].length - 1].toFixed(3)}`
      : `t ${signed(m.parameter[k])}${m.strains ? ` · ε_x ${signed(m.strains[k][0])}` : ""}`;
  }
}

// Legend entries for what is on the canvas, nothing else.
function legend(shown) {
  const box = $("legend");
  box.replaceChildren();
  const entry = (key, text, svgKey) => {
    if (!shown.has(key)) return;
    const span = el("span", { "data-key": key }, box, true);
    const icon = el("svg", { class: "key", width: 22, height: 12, viewBox: "0 0 22 12" }, span);
    svgKey(icon);
    span.appendChild(document.createTextNode(text));
  };
  const dot = (colours) => (s) => el("circle", { cx: 11, cy: 6, r: 5, fill: colours[0], stroke: colours[1] }, s);
  const line = (colour, width = 3) => (s) => el("line", { x1: 1, y1: 6, x2: 21, y2: 6, stroke: colour, "stroke-width": width }, s);
  entry("specified", "specified node", dot(COLOURS.specified));
  entry("unspecified", "unspecified node", dot(COLOURS.unspecified));
  entry("source", "source site", (s) => el("rect", { x: 6, y: 1, width: 10, height: 10, fill: "none", stroke: COLOURS.source, "stroke-width": 2 }, s));
  entry("target", "target site", (s) => el("polygon", { points: "11,0 17,6 11,12 5,6", fill: "none", stroke: COLOURS.target, "stroke-width": 2 }, s));
  entry("bar", "bar", line(COLOURS.bar));
  entry("rod", "rod", line(COLOURS.bar));
  entry("spring", "spring", (s) => el("path", { d: springPath([1, 6], [21, 6]), fill: "none", stroke: CHART.spring, "stroke-width": 1.2 }, s));
  entry("wall", "domain wall", (s) => el("circle", { cx: 11, cy: 6, r: 5, fill: CHART.wall, "fill-opacity": 0.3, stroke: CHART.wall, "stroke-width": 1.5 }, s));
  entry("input-pair", "input pair d₀", line("#000", 4));
  entry("pair", "pair d_k", (s) => el("line", { x1: 1, y1: 6, x2: 21, y2: 6, stroke: CHART.pair, "stroke-width": 2, "stroke-dasharray": "4 3" }, s));
  CONFORMATION_COLOURS.forEach((colour, c) => entry(`conformation-${c}`, `conformation ${c + 1}`,
    (s) => el("circle", { cx: 11, cy: 6, r: 4.5, fill: "none", stroke: colour, "stroke-width": 2 }, s)));
  entry("track", "node paths", line("#c6dbef", 2));
  state.motions.forEach((_, m) => entry(`motion-${m}`, `motion ${m + 1}`, line(COLOURS.motions[m % 4])));
  entry("mode", state.motionPath && !state.motionPath.own ? "zero mode (arrows at t = 0)" : "zero mode", line(COLOURS.motions[0]));
  state.spaces.forEach((_, m) => entry(`space-${m}`, `solution space${state.spaces.length > 1 ? " " + (m + 1) : ""}`, line(COLOURS.spaces[m % 4], 2)));
  entry("crossing", "crossing", (s) => el("circle", { cx: 11, cy: 6, r: 4, fill: "none", stroke: "#000", "stroke-width": 2 }, s));
  entry("path", "trajectory, start → end", (s) => {
    COLOURS.progress.forEach((c, i) => el("line", { x1: 1 + 5 * i, y1: 6, x2: 6 + 5 * i, y2: 6, stroke: c, "stroke-width": 3 }, s));
  });
}

// ----------------------------------------------------------------------------- pointer

function pointerPage(event) {
  const box = $("canvas").getBoundingClientRect();
  return [(event.clientX - box.left) * WIDTH / box.width, (event.clientY - box.top) * HEIGHT / box.height];
}

const pointerWorld = (event) => state.map.toWorld(pointerPage(event));

function onPointerDown(event) {
  if ((state.frame && state.frame.dim === 3) || (!state.frame && sketchDim() === 3) || (state.example && state.example.dim === 3)) {
    state.drag = { rotate: true, x: event.clientX, y: event.clientY, x0: event.clientX, y0: event.clientY };
    $("canvas").setPointerCapture(event.pointerId);
    return;
  }
  if (["auxetic", "multistable", "chain"].includes(state.kind) || state.example) return;
  const w = pointerWorld(event), target = event.target;
  if (state.kind === "draw" && document.querySelector("input[name=place]:checked").value === "unspecified") {
    if (!state.frame) placeUnspecified(w, target.classList.contains("crossing") ? Number(target.dataset.crossing) : null);
    else say("Design placed this frame's nodes: edit the drawing (or Undo) to place nodes by hand.", true);
    return;
  }
  let i;
  if (target.dataset.drawn !== undefined) i = Number(target.dataset.drawn);
  else if (state.network) {
    if (target.dataset.network === undefined) return;  // sites sit on the network's nodes
    const index = Number(target.dataset.network), x = state.network.positions[index];
    state.nodes.push({ x, role: document.querySelector("input[name=role]:checked").value, index });
    state.motions.forEach((m) => m.push([0, 0]));
    i = state.nodes.length - 1;
  } else {
    if (state.frame && !state.fromDrawing) return;
    const x = [snap(w[0], SNAP_POSITION), snap(w[1], SNAP_POSITION)];
    if (state.nodes.some((n) => Math.hypot(n.x[0] - x[0], n.x[1] - x[1]) < 1e-9)) return;
    const role = state.kind === "allostery" ? document.querySelector("input[name=role]:checked").value : "specified";
    state.nodes.push({ x, role });
    state.motions.forEach((m) => m.push([0, 0]));
    i = state.nodes.length - 1;
  }
  state.drag = { node: i };
  $("canvas").setPointerCapture(event.pointerId);
  edited();
}

function onPointerMove(event) {
  if (!state.drag) return;
  if (state.drag.rotate) {
    state.view[0] -= (event.clientX - state.drag.x) * 0.5;
    state.view[1] = Math.max(-89, Math.min(89, state.view[1] + (event.clientY - state.drag.y) * 0.5));
    state.drag.x = event.clientX; state.drag.y = event.clientY;
    draw();
    state.timings.turn.push(performance.now() - event.timeStamp);
    return;
  }
  const n = state.nodes[state.drag.node], w = pointerWorld(event);
  const m = state.kind === "draw" ? state.motion : 0;
  state.motions[m][state.drag.node] = [snap(w[0] - n.x[0], SNAP_MOTION), snap(w[1] - n.x[1], SNAP_MOTION)];
  edited();
  // From the pointer event to the space recomputed and redrawn (queueing included).
  state.timings.live.push(performance.now() - event.timeStamp);
}

function onPointerUp(event) {
  const drag = state.drag;
  state.drag = null;
  // 3D: a click that did not turn the view places an unspecified node (when so chosen).
  if (drag && drag.rotate && event.type === "pointerup" && Math.hypot(event.clientX - drag.x0, event.clientY - drag.y0) < CLICK_SLOP
      && sketching() && sketchDim() === 3 && !state.frame && $("place-3d").checked) placeUnspecified3d(event);
}

// A drawing changed: the old design no longer belongs to it.
function edited() {
  if (state.response) clearDesign();
  else if (state.pending) {  // a design on the way is of the old drawing
    state.designs++;
    state.pending = false;
    say("the drawing changed while it was being designed: press Design again.");
  }
  state.placed = [];
  updateSpaces();
  describeSpaces();
  draw();
}

// An unspecified node on the space nearest the click (or at a crossing of two spaces), joined to
// every specified node; a click farther than 20 px from every space places nothing.
function placeUnspecified(w, crossing) {
  let best = null;
  if (crossing !== null) best = state.crossings[crossing];
  else if (state.spaces.length > 1) {
    for (const q of state.crossings) if (!best || Math.hypot(q[0] - w[0], q[1] - w[1]) < Math.hypot(best[0] - w[0], best[1] - w[1])) best = q;
  } else {
    for (const s of state.spaces) {
      for (const q of [...s.curves.flat(), ...s.points.map((p) => p.position)]) {
        if (!best || Math.hypot(q[0] - w[0], q[1] - w[1]) < Math.hypot(best[0] - w[0], best[1] - w[1])) best = q;
      }
    }
  }
  if (!best || Math.hypot(best[0] - w[0], best[1] - w[1]) * state.map.scale > PICK_RADIUS) {
    say(state.spaces.length > 1 ? "click at a crossing of the solution spaces." : "click on the solution space.", true);
    return;
  }
  state.placed.push({ x: best });
  draw();
  checkPlaced();
}

// 3D: the node where the ray through the clicked pixel first meets the surface inside its box
// (exact: SolutionSpace.hit); else (a curve, or beside the surface's outline) the drawn point
// nearest the click on the page, within PICK_RADIUS, moved onto the space (SolutionSpace.project).
// Its motion follows from the linear system (x_i − p)·v = (x_i − p)·u_i (SolutionSpace.motionAt).
function placeUnspecified3d(event) {
  const space = state.spaces[0];
  if (!space || !["quadric", "conic"].includes(space.kind)) { say("there is no drawn solution space to place a node on.", true); return; }
  const [right, up, toward] = viewBasis(state.view), [s0, s1] = pointerWorld(event);
  const depth = specifiedNodes().reduce((t, n) => t + n.x.reduce((r, v, a) => r + v * toward[a], 0), 0) / specifiedNodes().length;
  const origin = [0, 1, 2].map((a) => s0 * right[a] + s1 * up[a] + depth * toward[a]);
  let p = space.kind === "quadric" ? SolutionSpace.hit(space, origin, toward.map((v) => -v)) : null;
  if (!p) {
    const [px, py] = pointerPage(event);
    let best = null, gap = Infinity;
    for (const q of space.curves.flat()) {
      const [qx, qy] = state.map.toPage(q), d = Math.hypot(qx - px, qy - py);
      if (d < gap) { gap = d; best = q; }
    }
    if (gap > PICK_RADIUS) { say("click on the solution space.", true); return; }
    p = SolutionSpace.project(space, best);
  }
  state.placed.push({ x: p, u: SolutionSpace.motionAt(space, p) });
  draw();
  checkPlaced();
}

// The frame built by hand: the specified nodes, the placed nodes, a bar from each placed node to
// every specified node.
function handBuiltFrame() {
  const spec = specifiedNodes(), k = spec.length;
  return { dim: sketchDim(), positions: [...spec.map((n) => n.x), ...state.placed.map((n) => n.x)],
           edges: state.placed.flatMap((_, j) => spec.map((__, i) => [i, k + j])), specified: spec.map((_, i) => i) };
}

// The frame built by hand analysed by the service: does it leave only the drawn motions?
async function checkPlaced() {
  // Another node placed meanwhile (its answer follows), or Design pressed (its answer is the
  // news): this answer, or its refusal, says nothing.
  const placed = state.placed.length, seq = state.designs;
  const current = () => state.placed.length === placed && state.designs === seq;
  let a;
  try { a = await post("/v1/analyze", { frame: handBuiltFrame() }); } catch (e) { if (current()) say(e.message, true); return; }
  if (!current()) return;
  say(`built by hand: ${a.nodes} nodes, ${a.edges} bars, ${a.nontrivial_zero_modes} non-rigid zero mode${a.nontrivial_zero_modes === 1 ? "" : "s"}, ${a.self_stresses} self-stress${a.self_stresses === 1 ? "" : "es"} `
      + (sketchDim() === 3 ? "(Design uses this frame; Clear placed lets it place nodes judiciously)." : "(Design places nodes judiciously instead)."));
}

// ----------------------------------------------------------------------------- design

function drawnRequest() {
  if (state.kind === "auxetic") {
    const request = { dim: 2, cells: [Number($("cells-x").value), Number($("cells-y").value)], poisson_ratio: Number($("nu").value) };
    const range = $("strain-range").value.trim();
    if (range) {
      const ends = range.split(/[ ,;]+/).map(Number);
      if (ends.length !== 2 || ends.some((v) => !Number.isFinite(v))) throw new Error("finite strain: give two numbers, e.g. -0.05, 0.05.");
      request.finite_strain = { strain_range: ends };
    }
    if ($("tolerance").checked) request.tolerance = {};
    return ["/v1/design/auxetic", request];
  }
  if (state.kind === "multistable") {
    const options = { seed: 0 }, barrier = $("barrier").value.trim();
    if (barrier) options.barrier = Number(barrier);
    return ["/v1/design/multistable", { dim: 2, conformations: state.conformations, options }];
  }
  if (state.kind === "chain" && chainSource() === "given") {
    const m = state.module;
    return ["/v1/map", { frame: { dim: 2, positions: m.positions, edges: m.edges }, input_pair: m.input_pair, output_pair: m.output_pair }];
  }
  if (state.kind === "chain" && $("soliton").checked) {
    const soliton = { n_modules: Number($("n-modules").value), stiffness: Number($("stiffness").value) };
    return ["/v1/design/sequential", { features: state.features, soliton }];
  }
  if (state.kind === "chain") {
    const chain = { n_modules: Number($("n-modules").value) }, d0 = $("d0").value.trim();
    if (d0) chain.d0 = Number(d0);
    return ["/v1/design/sequential", { features: state.features, chain }];
  }
  const options = $("tolerance").checked ? { tolerance: {} } : {};
  if (state.example) return ["/v1/design", { ...state.example, options: { ...state.example.options, ...options } }];
  if (state.kind === "allostery") {
    const site = (role) => {
      const idx = state.nodes.map((n, i) => [n, i]).filter(([n]) => n.role === role);
      return { positions: idx.map(([n]) => n.x), motion: idx.map(([, i]) => state.motions[0][i]) };
    };
    const source = site("source"), target = site("target");
    if (!source.positions.length || !target.positions.length) throw new Error("place at least one source and one target node.");
    if (state.network) {
      const indices = (role) => state.nodes.filter((n) => n.role === role).map((n) => n.index);
      return ["/v1/design/allosteric/network", {
        frame: state.network, source: indices("source"), target: indices("target"),
        source_motion: source.motion, target_motion: target.motion,
      }];
    }
    return ["/v1/design/allosteric", { dim: 2, source, target, options }];
  }
  const spec = state.nodes.map((n, i) => [n, i]).filter(([n]) => n.role === "specified");
  if (state.kind === "space3d") {
    return ["/v1/design", { dim: 3, positions: spec.map(([n]) => n.x), motions: [spec.map(([, i]) => state.motions[0][i])], options: { seed: 0, ...state.options, ...options } }];
  }
  if (spec.length < 2) throw new Error("place at least two specified nodes and drag their motions.");
  const motions = state.motions.map((m) => spec.map(([, i]) => m[i])).filter((m) => m.some((u) => u[0] || u[1]));
  if (!motions.length) throw new Error("drag from a node to give it a motion.");
  return ["/v1/design", { dim: 2, positions: spec.map(([n]) => n.x), motions, options: { seed: 0, ...state.options, ...options } }];
}

// 3D with nodes placed by hand: that frame is the design, as the service's analysis finds it
// (it must leave exactly the one target motion: one non-rigid zero mode, no self-stress). The
// mode is u_S on the specified nodes and each placed node's motion from the linear system.
async function designedByHand() {
  const frame = handBuiltFrame(), a = await post("/v1/analyze", { frame });
  if (a.nontrivial_zero_modes !== 1 || a.self_stresses !== 0) {
    throw new Error(`the frame built by hand has ${a.nontrivial_zero_modes} non-rigid zero modes and ${a.self_stresses} self-stresses, `
      + "not the one target motion: place more nodes (five on the surface of four specified nodes, in general position), or Clear placed and let Design place them.");
  }
  const { modes, stresses, ...analysis } = a;
  const motion = state.nodes.map((n, i) => [n, state.motions[0][i]]).filter(([n]) => n.role === "specified").map(([, u]) => u);
  return { frame, modes: [[...motion, ...state.placed.map((n) => n.u)]],
           report: { analysis, target_zero_modes: 7, unspecified_nodes: state.placed.length, bars: frame.edges.length, placed_by_hand: true } };
}

async function design(event) {
  const t0 = event && event.timeStamp ? event.timeStamp : performance.now();
  const byHand = state.kind === "space3d" && !state.example && state.placed.length > 0;
  let endpoint, request;
  if (!byHand) try { [endpoint, request] = drawnRequest(); } catch (e) { clearDesign(); say(e.message, true); return; }
  clearDesign();
  const seq = state.designs;  // clearDesign() (an edit, another tab, a new design) replaces it
  const wanted = () => state.designs === seq;
  if (!byHand) state.placed = [];
  say(byHand ? "the frame built by hand: asking the service's analysis (/v1/analyze) …" : `designing (${endpoint}) …`);
  // A drawn 2D design answers in milliseconds; the rest may take seconds: a job with progress.
  // (Allostery in a given network has no job endpoint: it is asked directly too.)
  // (So are a module's map and a sequential design unless the service runs it as a job: on a
  // worker all the same, the service offloads it.)
  const direct = (endpoint === "/v1/design" && request.dim === 2) || endpoint === "/v1/design/allosteric/network"
    || endpoint === "/v1/map" || (endpoint === "/v1/design/sequential" && !state.jobEndpoints.includes(endpoint));
  try {
    state.pending = true;
    let response = byHand ? await designedByHand() : direct ? await post(endpoint, request) : await runJob(endpoint, request, "designing", wanted);
    if (!wanted()) return;
    state.pending = false;  // the drawing changed, another tab was chosen or Design pressed again
    // A given module's map is drawn as a designed module's is, without features or chain.
    if (endpoint === "/v1/map") response = { map: response, module: { ...request, frame: { ...request.frame, specified: [] } }, features: [], chain: null };
    const own = ownMotion(response);
    state.response = response;
    state.frame = own ? own.frame : response.frame;
    state.modes = response.modes || [];
    state.mode = 0;
    const modeSelect = $("mode-select");
    modeSelect.replaceChildren();
    state.modes.forEach((_, m) => { el("option", { value: m }, modeSelect, true).textContent = `mode ${m + 1}`; });
    modeSelect.hidden = state.modes.length < 2;
    state.fromDrawing = direct && !state.example && !state.network;
    const report = response.report || {};
    state.sites = { source: report.source || [], target: report.target || [] };
    state.appearAt = performance.now();
    draw();
    requestAnimationFrame(() => state.timings.design.push(performance.now() - t0));
    enableActions();
    if (own) {
      showOwnMotion(own.motion);
      // Rods and springs, a chain and a given module's map export as designs do (springs as their own cells).
      await Promise.all([response.landscape || response.map ? listDownloads() : null, checkMap(response)]);
      return;
    }
    say(`designed: ${state.frame.positions.length} nodes, ${state.frame.edges.length} bars; tracing the finite motion …`);
    report_();
    await Promise.all([traceMotion(), listDownloads()]);
  } catch (e) {
    if (!wanted()) return;  // a refusal of a replaced design says nothing of the current one
    state.pending = false;
    clearDesign();
    say(e.message, true);
  }
}

const REFINE_TITLE = "Move the unspecified nodes so the finite motion follows the arrows (IPOPT)";
// Refine applies to a design with specified nodes and one motion; Certify to any but a multistable
// design or a chain (they come with their own checks).
function enableActions() {
  const f = state.frame, own = Boolean(state.response && ownMotion(state.response));
  const fits = f && !own && state.modes.length === 1 && f.specified.length >= 2;
  $("refine").disabled = !fits || state.running.has("refine");
  // Why not, on hover: a disabled button that says nothing looks broken.
  $("refine").title = fits || !f ? REFINE_TITLE
    : `Refine follows one motion of two or more specified nodes; this design has ${own ? "its own motion" : `${state.modes.length} motions, ${f.specified.length} specified nodes`}.`;
  $("certify").disabled = !f || own || state.running.has("certify");
}

function clearDesign() {
  stop();
  state.designs++;
  Object.assign(state, { response: null, frame: null, modes: [], sites: {}, motionPath: null,
                         refined: null, refinedPath: null, certificate: null, fromDrawing: false, mapCheck: null });
  for (const id of ["slider", "play", "refine", "certify"]) $(id).disabled = true;
  $("slider").max = $("slider").value = 0;
  $("where").textContent = "";
  $("downloads").replaceChildren();
  $("compare").hidden = true;
  report_();
  draw();
}

// A multistable design and a verified chain come with their motion (the landscape's samples,
// the chain's conformations along its traced motion): played as the service traced it.
function ownMotion(response) {
  if (response.landscape) {
    const land = response.landscape;
    return { frame: response.frame, motion: { own: "landscape", path: land.positions, parameter: land.arclength,
                                                reference_index: land.conformation_samples[0] } };
  }
  if (response.soliton) {
    // The drive from the stable end towards the unstable one: Play walks the wall out along the chain.
    // It starts where the wall has entered the chain.
    const sol = response.soliton, c = response.chain, order = sol.drive.map((_, j) => j).reverse();
    const pick = (a) => order.map((j) => a[j]), wall = pick(sol.wall);
    return { frame: c.frame, motion: { own: "soliton", path: pick(sol.rows).map((row) => c.path[row]), parameter: pick(sol.drive),
                                       rows: pick(sol.rows), wall, point: pick(sol.wall_point), energy: pick(sol.energy),
                                       offset: pick(sol.drive).map((d) => Math.abs(d - sol.unstable.d)),
                                       reference_index: Math.max(0, wall.findIndex((w) => w !== null)) } };
  }
  if (response.map) {
    const c = response.chain;
    if (!c) return { frame: response.module.frame, motion: null };
    return { frame: c.frame, motion: { own: "chain", path: c.path, parameter: c.distances.map((d) => d[0]), reference_index: c.reference_index } };
  }
  return null;
}

function showOwnMotion(motion) {
  state.motionPath = motion;
  const slider = $("slider");
  if (motion) {
    slider.max = motion.path.length - 1;
    slider.value = motion.reference_index;
  }
  slider.disabled = $("play").disabled = !motion;
  const f = state.frame, springs = state.response.springs || (state.response.soliton && state.response.soliton.springs);
  const mapped = state.response.features && !state.response.features.length;
  say(`${mapped ? "mapped" : "designed"}: ${f.positions.length} nodes, ${f.edges.length} ${springs ? `rods, ${springs.pairs.length} springs` : "bars"}`
      + (motion ? `; its motion in ${motion.path.length} samples: press Play or drag the slider.` : "."));
  draw();
  report_();
}

// The designed module's map asked of POST /v1/map at the chain's iterates d_0 … d_{n−1}: f(d_k)
// from the single module against the chain's d_{k+1} (the report's "/v1/map check").
async function checkMap(response) {
  const c = response.chain, m = response.module;
  if (!c) return;
  const frame = state.frame;
  const body = await post("/v1/map", { frame: { dim: 2, positions: m.frame.positions, edges: m.frame.edges },
                                       input_pair: m.input_pair, output_pair: m.output_pair, at: c.iterates.slice(0, -1) });
  if (state.frame !== frame) return;
  const deviation = Math.max(...body.evaluated.map((e, k) => Math.abs(e.d_out - c.iterates[k + 1]) / c.iterates[k + 1]));
  state.mapCheck = { evaluated: body.evaluated, deviation };
  report_();
}

async function traceMotion() {
  if (!state.frame) return;
  const a = Number($("amplitude").value);
  const body = { frame: state.frame, amplitude: a, on_singularity: "report" };
  if (state.modes.length) body.mode = state.modes[state.mode];
  // The service's ε along the path for the arrows' target x_S + a·(r_S/ρ_u)·u_S (as /v1/refine).
  if (fidelityApplies()) body.epsilon_curve = { amplitude: a, motion: specifiedRows(state.modes[0]) };
  if (state.response.report && state.response.report.boundary) body.boundary = state.response.report.boundary;
  const frame = state.frame;
  try {
    const motion = await post("/v1/motion", body);
    if (state.frame !== frame) return;  // redesigned meanwhile
    state.motionPath = motion;
    const slider = $("slider");
    slider.max = motion.path.length - 1;
    slider.value = motion.reference_index;
    slider.disabled = false;
    $("play").disabled = false;
    say(`finite motion: ${motion.path.length} configurations (${motion.status}); press Play or drag the slider.${departure()}`);
  } catch (e) {
    state.motionPath = null;
    $("slider").disabled = true;
    $("play").disabled = true;
    say("no finite motion: " + e.message, true);
  }
  draw();
  report_();
  if (state.refined) await traceRefined();
  else if (state.motionPath && fidelityApplies()) compare();
}

// ε(a) is defined for a design with specified nodes and one motion (as POST /v1/refine).
const fidelityApplies = () => state.frame.specified.length >= 2 && state.modes.length === 1;

// One sentence when the finite path leaves the arrows: the service's ε at the amplitude
// (POST /v1/motion's epsilon_curve, the last of its amplitudes) above DEPARTS.
function departure() {
  const curve = state.motionPath.epsilon_curve;
  if (!curve) return "";
  const last = curve.epsilon.length - 1, eps = curve.epsilon[last], a = curve.amplitudes[last];
  const bound = curve.at_end[last] ? "≥" : "=";  // ≥: the path ends before its closest point
  return eps > DEPARTS ? ` The finite path leaves the arrows (ε ${bound} ${fmt(eps, 2)} at a = ${a.toFixed(2)}: the design is exact only to first order); Refine moves the unspecified nodes so that it follows them.` : "";
}

function stop() {
  if (state.timer) clearInterval(state.timer);
  state.timer = null;
  $("play").textContent = "Play";
}

function play() {
  if (state.timer) { stop(); return; }
  const slider = $("slider");
  // About 100 frames a sweep: a chain's long path plays in seconds too.
  let direction = Math.max(1, Math.round((Number(slider.max) + 1) / 100));
  $("play").textContent = "Pause";
  state.timer = setInterval(() => {
    let k = Number(slider.value) + direction;
    if (k > Number(slider.max) || k < 0) { direction = -direction; k = Math.min(Math.max(k + 2 * direction, 0), Number(slider.max)); }
    slider.value = k;
    draw();
  }, 50);
}

// ----------------------------------------------------------------------------- refine, certify

const specifiedRows = (mode) => state.frame.specified.map((i) => mode[i]);

// A job on the current design with its button disabled meanwhile; ``use`` takes the result
// unless the design changed while it ran.
async function designJob(button, label, endpoint, request, use) {
  const frame = state.frame, current = () => state.frame === frame;
  $(button).disabled = true;
  state.running.add(button);
  try {
    const result = await runJob(endpoint, request, label, current);
    if (current()) await use(result);
  } catch (e) {
    if (current()) say(`${label}: ${e.message}`, true);
  } finally {
    state.running.delete(button);
    enableActions();
    report_();
  }
}

async function refine() {
  if (!state.frame) return;
  const f = state.frame;
  const request = {
    frame: { dim: f.dim, positions: f.positions, edges: f.edges, specified: f.specified },
    motion: specifiedRows(state.modes[0]), amplitude: Number($("amplitude").value), options: { max_time_s: 10 },
  };
  await designJob("refine", "refining", "/v1/refine", request, async (result) => {
    state.refined = result;
    say(`refined: ε ${fmt(result.epsilon_before)} → ${fmt(result.epsilon_after)} (IPOPT ${result.ipopt_status}, ${result.iterations} iterations).`);
    await traceRefined();
  });
}

async function traceRefined() {
  const r = state.refined;
  try {
    state.refinedPath = await post("/v1/motion", {
      frame: r.frame, mode: r.modes ? r.modes[0] : undefined, amplitude: Number($("amplitude").value), on_singularity: "report",
    });
  } catch (e) {
    state.refinedPath = null;
  }
  compare();
}

async function certify() {
  if (!state.frame) return;
  const f = state.frame;
  const request = { frame: { dim: f.dim, positions: f.positions, edges: f.edges }, modes: state.modes };
  await designJob("certify", "certifying", "/v1/certify", request, (result) => {
    state.certificate = result;
    const p = result.prestress, g = result.rigidity_margin || result.margin;
    const stable = p.prestress_stable ? `prestress stable (${p.decided_by})` : p.decided_by === "no_self_stress"
      ? "no self-stress, so nothing stiffens the designed motion: it stays free, as designed" : `not prestress stable (${p.decided_by})`;
    say(`certified: ${stable}${g ? `; ${g.undesigned_zero_modes} undesigned zero modes, rigidity margin ${fmt(g.uniform)}` : ""}.`);
  });
}

function miniFrame(svg, frame, path) {
  svg.replaceChildren();
  if (!frame) {
    el("text", { x: 150, y: 125, "text-anchor": "middle", fill: "#999", "font-size": 13 }, svg).textContent = "press Refine";
    return;
  }
  const configs = path ? path.path : [frame.positions], project = projector(frame.dim);
  let lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
  for (const c of configs) for (const p of c) { const s = project(p); lo = [Math.min(lo[0], s[0]), Math.min(lo[1], s[1])]; hi = [Math.max(hi[0], s[0]), Math.max(hi[1], s[1])]; }
  const sc = Math.min(270 / ((hi[0] - lo[0]) || 1), 210 / ((hi[1] - lo[1]) || 1));
  const page = (p) => { const s = project(p); return [15 + (s[0] - lo[0]) * sc, 225 - (s[1] - lo[1]) * sc]; };
  if (path) {
    for (let i = 0; i < frame.positions.length; i++) {
      const pts = path.path.map((c) => page(c[i]).map((v) => v.toFixed(1)).join(",")).join(" ");
      el("polyline", { points: pts, fill: "none", stroke: COLOURS.progress[1], "stroke-width": 1 }, svg);
    }
  }
  const p = frame.positions.map(page), spec = new Set(frame.specified);
  frame.edges.forEach(([i, j]) => el("line", { x1: p[i][0], y1: p[i][1], x2: p[j][0], y2: p[j][1], stroke: COLOURS.bar, "stroke-width": 1.5 }, svg));
  p.forEach((q, i) => el("circle", { cx: q[0], cy: q[1], r: 3.5, fill: spec.has(i) ? COLOURS.specified[0] : COLOURS.unspecified[0] }, svg));
}

function compare() {
  $("compare").hidden = false;
  miniFrame($("path-linear"), state.frame, state.motionPath);
  miniFrame($("path-refined"), state.refined && state.refined.frame, state.refinedPath);
  const chart = $("epsilon");
  chart.replaceChildren();
  // The service's ε(a), measured on the constraint manifold: POST /v1/refine's curves before and
  // after, or before a refinement POST /v1/motion's along the linear design's path.
  const refined = state.refined && state.refined.epsilon_curve, linear = state.motionPath && state.motionPath.epsilon_curve;
  const source = refined || linear;
  if (!source) return;
  const amplitudes = source.amplitudes, top = amplitudes[amplitudes.length - 1];
  const curves = refined ? [[COLOURS.spaces[0], "linear"], [COLOURS.spaces[1], "refined"]] : [[COLOURS.spaces[0], "linear"]];
  const values = refined ? [refined.before, refined.after] : [linear.epsilon];
  const ymax = Math.max(1e-3, ...values.flat().filter(Number.isFinite)) * 1.1;
  const X = (a) => 40 + 245 * a / top, Y = (e) => 215 - 170 * e / ymax;  // labels above y = 40
  el("line", { x1: 40, y1: 215, x2: 290, y2: 215, stroke: "#888" }, chart);
  el("line", { x1: 40, y1: 45, x2: 40, y2: 215, stroke: "#888" }, chart);
  const label = (x, y, text, anchor = "middle", attrs = {}) => { el("text", { x, y, "font-size": 11, "text-anchor": anchor, fill: "#444", ...attrs }, chart).textContent = text; };
  label(165, 236, "amplitude a");
  label(36, 49, fmt(ymax, 2), "end");
  label(36, 218, "0", "end");
  label(290, 228, fmt(top, 2), "end");
  curves.forEach(([colour, name], c) => {
    const pts = amplitudes.map((a, i) => `${X(a).toFixed(1)},${Y(values[c][i]).toFixed(1)}`).join(" ");
    el("polyline", { class: `epsilon ${name}`, points: pts, fill: "none", stroke: colour, "stroke-width": 2 }, chart);
    label(285, 14 + 14 * c, `${name}: ε(${fmt(top, 2)}) = ${fmt(values[c][values[c].length - 1])}`, "end", { class: `epsilon-label ${name}` });
  });
}

// ----------------------------------------------------------------------------- report

// [label, value, unit, meaning] rows of everything known about the design.
function reportRows() {
  const r = state.response;
  if (!r) return [];
  const rep = r.report || {}, a = rep.analysis || {}, rows = [["Design"]];
  const add = (label, value, unit, meaning) => { if (value !== undefined && value !== null) rows.push([label, value, unit, meaning]); };
  add("nodes N", a.nodes, "", "Joints of the frame, specified and unspecified.");
  add("unspecified nodes", rep.unspecified_nodes, "", "Nodes the designer placed on the solution spaces.");
  add("bars N_B", a.edges, "", "Rigid bars; each keeps its length to first order.");
  add("zero modes", a.zero_modes, "", "dim N(C) = dN − rank C: rigid motions plus the designed motions.");
  add("non-rigid zero modes", a.nontrivial_zero_modes, "", "Zero modes beyond rigid motions: should equal the number of motions you asked for.");
  add("self-stresses", a.self_stresses, "", "N_B − rank C: bars that fight each other (0 keeps the motion finite).");
  if (a.rank_gap) add("rank gap σ_r / σ_r+1", `${fmt(a.rank_gap.last_nonzero)} / ${fmt(a.rank_gap.first_zero)}`, "", "Smallest nonzero and largest zero singular value of the scale-normalised C: a wide gap means the counts are decided robustly.");
  add("mode residual", rep.mode_residual, "relative", "max ‖C u‖ / (‖C‖ ‖u‖): how exactly the designed motion is a zero mode.");
  add("conditioning", rep.conditioning, "", "Smallest nonzero singular value of the normalised C: small means nearly another mode.");
  add("Poisson ratio ν", r.poisson_ratio, "", "−ε_y/ε_x of the sheet's motion, to first order.");
  if (rep.strain_range) {
    const s = rep.strain_range;
    const ends = [s.lower, s.upper].map((e) => (e && typeof e === "object" ? fmt(e.strain) : fmt(e)));
    add("strain range ε_x", `${ends[0]} … ${ends[1]}`, "strain", "How far the sheet can be strained before a singular point, two nodes touching or bars crossing.");
  }
  if (rep.finite_strain) add("ν deviation over strain", rep.finite_strain.max_deviation, "", "max |ν_secant − ν| over the finite-strain range, measured on the whole sheet.");
  add("target error", rep.target_error, "relative", "How far the achieved target motion is from the one prescribed.");
  add("bonds changed", rep.bonds_changed, "", "Bars removed from the given network plus bars added to it.");
  const tol = rep.tolerance;
  if (tol) {
    const budget = `keeping every designed quantity within ${fmt(100 * tol.budget)} % (linearised, checked by a Monte Carlo of ${tol.samples} frames). ${tol.summary}`;
    add("tolerance, bar lengths", tol.bar_lengths, "fraction", `How far each bar may be off its length, ${budget}`);
    add("tolerance, pins", tol.pin_positions, "× mean bar", `How far each pin may be off, as a fraction of the mean bar length (${fmt(tol.mean_bar_length)}), ${budget}`);
  }
  if (rep.timings_ms && rep.timings_ms.total !== undefined) add("design time", rep.timings_ms.total, "ms", "Time the service spent designing.");
  beyondOneMotion(r, rows, add);
  const m = state.motionPath;
  if (m && !m.own) {
    rows.push(["Finite motion"]);
    add("configurations", m.path.length, "", "Points traced along the nonlinear motion.");
    add("parameter range", `${fmt(m.parameter[0])} … ${fmt(m.parameter[m.parameter.length - 1])}`, "", "Pseudo-arclength, RMS node displacement over the frame's RMS radius.");
    add("bar-length error", m.max_relative_bar_error, "relative", "Largest | |x_i − x_j| − l | / l along the path: every bar keeps its length.");
    add("status", m.status, "", "ok, or singular_path when the motion meets a branch point or locks before the amplitude.");
  }
  const f = state.refined;
  if (f) {
    rows.push(["Refinement"]);
    add("ε before", f.epsilon_before, "relative", "Finite-motion fidelity of the linear design: distance of the closest path point from x_S + Δ_S over ‖Δ_S‖.");
    add("ε after", f.epsilon_after, "relative", "The same for the refined frame, measured by continuation (independently of IPOPT).");
    add("amplitude a", f.amplitude, "relative", "RMS displacement of the specified nodes over their RMS radius.");
    add("IPOPT", `${f.ipopt_status}, ${f.iterations} it.`, "", "The optimiser's status and iterations.");
    add("refine time", f.time_ms, "ms", "Whole refinement, both ε measurements included.");
  }
  const c = state.certificate;
  if (c) {
    rows.push(["Certificate"]);
    const p = c.prestress;
    add("prestress stable", p.prestress_stable ? "yes" : "no", "", p.decided_by === "no_self_stress"
      ? "Decided by no_self_stress: without a self-stress nothing stiffens the frame's flexes — expected for a mechanism, whose designed motion must stay free; the rigidity margin is what resists every other motion."
      : `Decided by ${p.decided_by}: a self-stress makes every undesigned flex cost energy.`);
    if (p.decided_by === "sdp") add("prestress margin", `[${fmt(p.margin)}, ${fmt(p.margin_upper_bound)}]`, "stiffness", "Certified lower bound and upper bound of the SDP's margin.");
    const g = c.rigidity_margin || c.margin;
    if (g) {
      add("rigidity margin, uniform", g.uniform, "stiffness", "Smallest stiffness of any motion beyond rigid and designed ones, unit bar stiffness.");
      if (g.optimal !== null && g.optimal !== undefined) add("rigidity margin, optimal", `[${fmt(g.optimal)}, ${fmt(g.optimal_upper_bound)}]`, "stiffness", "Certificate bracket of the best margin over bar stiffnesses (SDP): the truth lies between.");
      add("undesigned zero modes", g.undesigned_zero_modes, "", "Zero modes that are neither rigid nor designed (0 for a correct design).");
    }
    if (c.self_stress) add("self-stresses (certified)", c.self_stress.count, "", "N_B − rank C with its singular-value evidence.");
  }
  return rows;
}

// Report rows of a multistable design (its minima) and of a module map with its chain.
function beyondOneMotion(r, rows, add) {
  const rep = r.report || {};
  if (r.minima) {
    rows.push(["Rods and springs"]);
    add("springs", rep.springs, "", "Springs (zig-zags), E = Σ k_s (|x_i − x_j| − L_s)² / 2; never where a rod is.");
    add("gap along the motion", rep.gap, "relative", "Smallest σ_r/σ_max of C along the motion: one non-rigid zero mode at every sample.");
    add("rod length mismatch", rep.max_length_mismatch, "relative", "Largest relative difference of a rod's length between the conformations.");
    add("barrier asked", rep.barrier, "k·L²", "The least energy barrier between neighbouring minima asked for (or its default); k = the largest spring stiffness, L = the unit of length.");
    r.minima.forEach((m) => {
      rows.push([`Minimum ${m.index + 1} (conformation ${m.index + 1})`]);
      add("energy E", m.energy, "k·L²", "The springs' energy in this conformation.");
      add("curvature E″(s)", m.curvature, "k", "Second derivative of E along the motion (s its arc length): > 0, a strict minimum along the motion.");
      add("slope E′(s)", m.slope, "k·L", "First derivative of E along the motion: 0 at a minimum, up to round-off.");
      add("barrier before", m.barrier_before, "k·L²", "Highest energy between the previous minimum and this one, minus E here.");
      add("barrier after", m.barrier_after, "k·L²", "Highest energy between this minimum and the next, minus E here.");
      add("Hessian λ_min", m.hessian_min_eigenvalue, "k", "Smallest eigenvalue of the full energy's Hessian (rods as stiff springs), rigid motions aside: > 0, stable against every small push, not only along the motion.");
      add("worst landing", m.worst_landing, "relative", "Farthest end of a relaxation from a seeded push from the relaxed minimum (over RMS radius · √N): small, it falls back.");
    });
  }
  if (r.map) {
    const m = r.map;
    rows.push(["Module map"]);
    add("module", `${r.module.frame.positions.length} nodes, ${r.module.frame.edges.length} bars`, "", `Input pair ${r.module.input_pair.join("–")}, output pair ${r.module.output_pair.join("–")}: d_out = f(d_in) along its motion.`);
    for (const f of r.features) {
      add(`f(${fmt(f.d_in, 4)})`, f.achieved_d_out, "L", `The designed module's f at d_in = ${fmt(f.d_in, 4)}, exact (Newton on its branch); asked ${fmt(f.d_out, 6)}.`);
      if (f.slope !== null) add(`f′(${fmt(f.d_in, 4)})`, f.achieved_slope, "", `Its slope there; asked ${fmt(f.slope, 6)} (|f′| < 1: stable).`);
    }
    add("feature deviation", r.deviation, "relative", `Largest relative miss of a feature: within map_rtol = ${fmt(r.map_rtol)}, checked by continuation.`);
    add("usable range", `${fmt(m.lower.d_in, 4)} … ${fmt(m.upper.d_in, 4)}`, "L", `d_in between the ends of the map's branch: ${m.lower.kind} below, ${m.upper.kind} above.`);
    m.fixed_points.forEach((p, i) => add(`fixed point ${i + 1}`, `${fmt(p.d, 6)}, f′ ${fmt(p.slope, 3)}`, "L", `f(d*) = d*; ${p.stable ? "stable (|f′| < 1): orbits near it converge" : "unstable (|f′| > 1): orbits leave it"}.`));
    add("IPOPT", r.solver_status, "", "The optimiser's status (the answer is verified by continuation, not by it).");
    const c = r.chain;
    if (c) {
      rows.push(["Chain"]);
      add("copies", c.pairs.length - 1, "", "Modules chained, the output pair of one the input pair of the next.");
      add("nodes, bars", `${c.frame.positions.length}, ${c.frame.edges.length}`, "", "The chained frame: one non-rigid zero mode.");
      add("samples", c.path.length, "", "Conformations of the chain along its traced motion (the animation).");
      add("chain deviation", c.deviation, "relative", "max |d_{k+1} − f(d_k)| / d_{k+1} along the chain's traced motion, f from the single module.");
      add("iterate deviation", c.iterate_deviation, "relative", "max |d_k − f^k(d_0)| / d_k: round-off amplified by Π|f′| (reported, not promised).");
      add("motion ends", c.ends.join(", "), "", "Why the traced motion ended each way: map_range (a copy reached its fold), singular_point or horizon.");
    }
    const sol = r.soliton;
    if (sol) {
      rows.push(["Soliton"]);
      add("springs", sol.springs.pairs.length, "", "One spring per copy (zig-zags), from an anchor held by a dyad to a node of the copy: E = Σ k (ℓ − L)²/2.");
      add("wall travel", sol.travel, "copies", `How far the wall (switched fraction ½) moves along the drive, monotonically; at least ${fmt(sol.required_travel)} promised.`);
      add("wall slope", `${fmt(sol.wall_slope, 3)} (predicted ${fmt(sol.predicted_wall_slope, 3)})`, "", "dw / d ln|d₀ − d_u| in the bulk, against −1/ln f′(d_u) linearised at d_u.");
      add("barrier", sol.barrier, "k·L²", "The largest E along the drive: the wall's energy.");
      for (const [label, u] of [["d_u", sol.unstable], ["d_s", sol.stable]]) {
        add(`uniform at ${label}`, `E ${fmt(u.energy, 2)}, λ_min ${fmt(u.hessian_min_eigenvalue, 3)}`, "",
            "Every copy at the fixed point: E (0, every spring at rest) and the smallest eigenvalue of the stiff-rod Hessian, rigid motions aside (> 0: a strict minimum).");
      }
    }
    if (state.mapCheck) add("POST /v1/map check", state.mapCheck.deviation, "relative", "f(d_k) of the designed module asked of POST /v1/map against the chain's d_{k+1}, largest relative difference.");
  }
}

function report_() {
  const body = $("report").tBodies[0];
  body.replaceChildren();
  // A section without rows (a module map has no "Design" counts) is not shown.
  const rows = reportRows().filter((row, i, all) => row.length > 1 || (all[i + 1] && all[i + 1].length > 1));
  $("report-empty").hidden = rows.length > 0;
  for (const [label, value, unit, meaning] of rows) {
    const tr = el("tr", {}, body, true);
    if (value === undefined) { tr.className = "section"; el("th", { colspan: 3 }, tr, true).textContent = label; continue; }
    tr.title = meaning;
    tr.dataset.row = label;
    el("th", {}, tr, true).textContent = label;
    el("td", { class: "value" }, tr, true).textContent = fmt(value, 4);
    el("td", { class: "unit" }, tr, true).textContent = unit;
  }
  const raw = { design: state.response, motion: state.motionPath && { ...state.motionPath, path: `(${state.motionPath.path.length} configurations)` },
                refinement: state.refined, certificate: state.certificate };
  // One line per vector (a position, a motion's row), not one per number.
  $("raw").textContent = state.response ? JSON.stringify(raw, null, 1).replace(/\[[-\d.e+,\s]*\]/g, (a) => a.replace(/\s+/g, "")) : "";
}

// ----------------------------------------------------------------------------- downloads

function designName() {
  return ($("name").value.trim() || "zeromode").replace(/[^A-Za-z0-9._-]+/g, "_");
}

async function listDownloads() {
  const box = $("downloads"), response = state.response;
  box.replaceChildren();
  if (!state.formats) state.formats = await (await api("GET", "/v1/export/formats")).json();
  if (state.response !== response) return;  // cleared or replaced meanwhile: no buttons for it
  // A module's map formats (map_csv, …) write a given module's map only (a /v1/map answer).
  for (const f of state.formats.filter((f) => f.available && (!f.map || givenMap()))) {
    const button = el("button", { type: "button", "data-format": f.name, "data-testid": `download-${f.name}`, title: f.description }, box, true);
    button.textContent = formatLabel(f);
    button.addEventListener("click", () => download(f));
  }
}

// A given module mapped as it is (Chain tab, "Map a given one"): its /v1/map answer, no chain.
const givenMap = () => Boolean(state.response && state.response.map && !state.response.chain);

// The format's human name: ours, else the service's description up to its first stop.
const formatLabel = (f) => FORMAT_LABELS[f.name] || f.description.split(/[.:;(]/)[0].trim();

async function download(format) {
  if (!state.response) return;
  const body = { format: format.name, document: givenMap() ? state.response.map : state.response, motion: { mode: 0 } };
  if (state.motionPath) { body.path = state.motionPath.path; body.parameter = state.motionPath.parameter; }
  say(`exporting ${formatLabel(format)} …`);
  try {
    const blob = await (await api("POST", "/v1/export", body)).blob();
    const link = document.createElement("a");
    link.href = URL.createObjectURL(blob);
    link.download = `${designName()}${format.name === "cut_svg" ? "_cut" : ""}${format.suffix}`;
    document.body.appendChild(link);
    link.click();
    link.remove();
    setTimeout(() => URL.revokeObjectURL(link.href), 10000);
    say(`saved ${link.download} (${blob.size} bytes).`);
  } catch (e) {
    say(e.message, true);
  }
}

// ----------------------------------------------------------------------------- kinds, examples

function setKind(kind) {
  state.kind = kind;
  for (const b of document.querySelectorAll(".tabs button")) b.setAttribute("aria-selected", String(b.dataset.kind === kind));
  for (const p of document.querySelectorAll("[data-for]")) p.hidden = !p.dataset.for.split(" ").includes(kind);
  $("hint").textContent = kind === "allostery"
    ? "Click to place source and target nodes (choose which below); drag from a node to set its motion."
    : "Click on the canvas to place a specified node; drag from a node to give it a motion.";
  state.example = null;
  if (kind === "auxetic" && $("name").value === "my_design") $("name").value = "auxetic_sheet";
  $("amplitude-row").hidden = kind === "multistable" || kind === "chain";
  for (const id of ["refine", "certify"]) $(id).hidden = kind === "multistable" || kind === "chain";
  clearSketch();
  if (kind === "space3d") fillTable(DEFAULT_3D.positions, DEFAULT_3D.motion);
  if (kind === "multistable" && !state.conformations.length) loadConformations(MULTISTABLE_EXAMPLE).catch((e) => say(e.message, true));
  if (kind === "chain" && !state.features.length) loadChainExamples().catch((e) => say(e.message, true));
  if (kind === "chain" && !state.module) {
    state.module = JSON.parse(JSON.stringify(GIVEN_MODULE));
    renderModule();
  }
}

// A drawing tab left keeps its drawing: coming back (by its tab) finds it as it was, undesigned.
const SKETCHED = ["draw", "allostery"];
function switchTab(kind) {
  if (SKETCHED.includes(state.kind)) {
    state.sketches[state.kind] = { nodes: state.nodes, motions: state.motions, network: state.network, options: state.options, name: $("name").value };
  }
  $("example").value = "";
  $("example-text").textContent = "";
  setKind(kind);
  const kept = state.sketches[kind];
  if (!SKETCHED.includes(kind) || !kept || !(kept.nodes.length || kept.network)) return;
  Object.assign(state, { nodes: kept.nodes, motions: kept.motions, network: kept.network, options: kept.options });
  kept.motions.slice(1).forEach((_, m) => { el("option", { value: m + 1 }, $("motion-index"), true).textContent = String(m + 2); });
  $("name").value = kept.name;
  edited();
}

// The given module of the Chain tab: the two-triangle module of docs/module_maps.md.
const GIVEN_MODULE = {
  positions: [[-1, 0], [1, 0], [-0.8, 1], [0.8, 1], [0.15, 0.45]],
  edges: [[0, 2], [0, 4], [2, 4], [1, 3], [1, 4], [3, 4]], input_pair: [0, 1], output_pair: [2, 3],
};
const chainSource = () => document.querySelector("input[name=chain-source]:checked").value;

function renderModule() {
  const body = $("module").tBodies[0];
  body.replaceChildren();
  state.module.positions.forEach((p, i) => {
    const tr = el("tr", {}, body, true);
    el("td", {}, tr, true).textContent = String(i + 1);
    p.forEach((v, a) => {
      const input = el("input", { type: "number", step: "0.05", value: v, "aria-label": `node ${i + 1}, ${"xy"[a]}`, "data-node": i, "data-axis": a },
                       el("td", {}, tr, true), true);
      input.addEventListener("input", () => { if (Number.isFinite(input.valueAsNumber)) { p[a] = input.valueAsNumber; clearDesign(); } });
    });
  });
}

// ----------------------------------------------------------------------------- multistable, chain forms

// The multistable form starts from this named example (GET /v1/examples).
const MULTISTABLE_EXAMPLE = "tristable_triangle_2d";

async function loadConformations(name) {
  const request = await (await api("GET", `/v1/examples/${encodeURIComponent(name)}/request`)).json();
  state.conformations = request.conformations.map((c) => c.map((p) => p.slice()));
  $("n-conformations").value = String(state.conformations.length);
  $("barrier").value = request.options && request.options.barrier ? String(request.options.barrier) : "";
  $("name").value = name;
  renderConformations();
  edited();
}

// One row per specified node: x, y in each conformation; every edit redraws the preview.
function renderConformations() {
  const table = $("conformations"), C = state.conformations.length;
  const head = el("tr", {}, null, true);
  el("th", {}, head, true);
  for (let c = 0; c < C; c++) {
    const th = el("th", { colspan: 2, style: `color: ${CONFORMATION_COLOURS[c % 3]}` }, head, true);
    th.textContent = `conformation ${c + 1}`;
  }
  table.tHead.replaceChildren(head);
  const body = table.tBodies[0];
  body.replaceChildren();
  (state.conformations[0] || []).forEach((_, i) => {
    const tr = el("tr", {}, body, true);
    el("td", {}, tr, true).textContent = String(i + 1);
    state.conformations.forEach((points, c) => points[i].forEach((v, a) => {
      const input = el("input", { type: "number", step: "0.05", value: v, "aria-label": `conformation ${c + 1}, node ${i + 1}, ${"xy"[a]}`,
                                  "data-conformation": c, "data-node": i, "data-axis": a }, el("td", {}, tr, true), true);
      input.addEventListener("input", () => { if (Number.isFinite(input.valueAsNumber)) { points[i][a] = input.valueAsNumber; edited(); } });
    }));
    const remove = el("button", { type: "button", title: "remove this node" }, el("td", {}, tr, true), true);
    remove.textContent = "×";
    remove.addEventListener("click", () => { state.conformations.forEach((c) => c.splice(i, 1)); renderConformations(); edited(); });
  });
}

function conformationCount() {
  const want = Number($("n-conformations").value), cs = state.conformations;
  while (cs.length > want) cs.pop();
  // A new conformation starts as the last one with its last node moved up a little.
  while (cs.length < want) cs.push(cs[cs.length - 1].map((p, i, all) => (i === all.length - 1 ? [p[0], p[1] + 0.15] : p.slice())));
  renderConformations();
  edited();
}

// The named examples of POST /v1/design/sequential are its OpenAPI examples (read once).
async function loadChainExamples() {
  if (!state.chainExamples) {
    const spec = await (await api("GET", "/openapi.json")).json();
    state.chainExamples = spec.paths["/v1/design/sequential"].post.requestBody.content["application/json"].examples;
    state.jobEndpoints = spec.components.schemas.JobRequest.properties.endpoint.enum || [];
    const select = $("chain-example");
    for (const [name, ex] of Object.entries(state.chainExamples)) {
      el("option", { value: name, title: ex.description }, select, true).textContent = ex.summary;
    }
  }
  pickChainExample($("chain-example").value || Object.keys(state.chainExamples)[0]);
}

function pickChainExample(name) {
  const ex = state.chainExamples[name];
  $("chain-example").value = name;
  $("chain-example-text").textContent = ex.description;
  state.features = JSON.parse(JSON.stringify(ex.value.features));
  const chain = ex.value.chain || ex.value.soliton || {};
  $("n-modules").value = String(chain.n_modules || 16);
  $("d0").value = chain.d0 === undefined ? "" : String(chain.d0);
  $("soliton").checked = Boolean(ex.value.soliton);
  $("stiffness").value = String(chain.stiffness || 1);
  solitonForm();
  $("name").value = `${name}_chain`;
  renderFeatures();
  clearDesign();
}

// A soliton has springs (their stiffness) and no d₀ (its drive is the whole way between the fixed points).
function solitonForm() {
  const soliton = $("soliton").checked;
  for (const e of document.querySelectorAll("[data-chain-only]")) e.hidden = soliton;
  for (const e of document.querySelectorAll("[data-soliton-only]")) e.hidden = !soliton;
}

// Each feature kind's fields: [path into the feature, label, default].
const FEATURE_FIELDS = {
  fixed_point: [[["d"], "d*", 1.5], [["slope"], "f′(d*)", 0.5]],
  period_two: [[["d1"], "d₁", 1.3], [["d2"], "d₂", 1.7]],
  range: [[["source", 0], "a", 1.2], [["source", 1], "b", 1.6], [["target", 0], "f(a)", 1.3], [["target", 1], "f(b)", 1.7]],
};
const FEATURE_NAMES = { fixed_point: "fixed pt", period_two: "2-cycle", range: "range" };

function renderFeatures() {
  const body = $("features").tBodies[0];
  body.replaceChildren();
  state.features.forEach((feature, n) => {
    const tr = el("tr", {}, body, true);
    const kind = el("select", { "aria-label": `feature ${n + 1}` }, el("td", {}, tr, true), true);
    for (const [k, label] of Object.entries(FEATURE_NAMES)) el("option", { value: k }, kind, true).textContent = label;
    kind.value = feature.kind;
    kind.addEventListener("change", () => {
      const fresh = { kind: kind.value };
      for (const [[key, i], , v] of FEATURE_FIELDS[kind.value]) {
        if (i === undefined) fresh[key] = v; else (fresh[key] = fresh[key] || [])[i] = v;
      }
      state.features[n] = fresh;
      renderFeatures();
      clearDesign();
    });
    for (const [[key, i], label] of FEATURE_FIELDS[feature.kind]) {
      const cell = el("td", {}, tr, true);
      el("span", { class: "field" }, cell, true).textContent = label;
      const input = el("input", { type: "number", step: "0.05", value: i === undefined ? feature[key] : feature[key][i], "aria-label": label }, cell, true);
      input.addEventListener("input", () => {
        if (!Number.isFinite(input.valueAsNumber)) return;
        if (i === undefined) feature[key] = input.valueAsNumber; else feature[key][i] = input.valueAsNumber;
        clearDesign();
      });
    }
    const remove = el("button", { type: "button", title: "remove this feature" }, el("td", {}, tr, true), true);
    remove.textContent = "×";
    remove.addEventListener("click", () => { state.features.splice(n, 1); renderFeatures(); clearDesign(); });
  });
}

// The 3D target as a table: one row per specified node, positions then motion; every edit
// recomputes the solution space.
function fillTable(positions, motion) {
  state.nodes = positions.map((x) => ({ x: x.slice(), role: "specified" }));
  state.motions = [motion.map((u) => u.slice())];
  renderTable();
  edited();
}

function renderTable() {
  const body = $("table3d").tBodies[0];
  body.replaceChildren();
  state.nodes.forEach((n, i) => {
    const tr = el("tr", {}, body, true);
    for (const [vector, a] of [0, 1, 2].map((a) => [n.x, a]).concat([0, 1, 2].map((a) => [state.motions[0][i], a]))) {
      const input = el("input", { type: "number", step: "0.1", value: vector[a], "aria-label": `node ${i + 1}` }, el("td", {}, tr, true), true);
      input.addEventListener("input", (event) => {
        if (!Number.isFinite(input.valueAsNumber)) return;
        vector[a] = input.valueAsNumber;
        edited();
        // From the edit to the space recomputed and redrawn (queueing included).
        state.timings.table.push(performance.now() - event.timeStamp);
      });
    }
    const remove = el("button", { type: "button", title: "remove this node" }, el("td", {}, tr, true), true);
    remove.textContent = "×";
    remove.addEventListener("click", () => { state.nodes.splice(i, 1); state.motions[0].splice(i, 1); renderTable(); edited(); });
  });
}

function clearSketch() {
  Object.assign(state, { network: null, nodes: [], motions: [[]], motion: 0, placed: [], options: {} });
  const select = $("motion-index");
  select.replaceChildren();
  el("option", { value: 0 }, select, true).textContent = "1";
  clearDesign();
  edited();
}

// A rigid triangulated sheet (rows shifted by half a spacing, each node joined to its six
// neighbours), centred in the window.
function triangulatedSheet([nx, ny], h) {
  const positions = [], edges = [], at = (i, j) => j * nx + i;
  for (let j = 0; j < ny; j++) for (let i = 0; i < nx; i++) {
    positions.push([(i - (nx - 1) / 2 + (j % 2 ? 0.25 : -0.25)) * h, (j - (ny - 1) / 2) * h * Math.sqrt(3) / 2]);
  }
  for (let j = 0; j < ny; j++) for (let i = 0; i < nx; i++) {
    if (i + 1 < nx) edges.push([at(i, j), at(i + 1, j)]);
    if (j + 1 < ny) {
      edges.push([at(i, j), at(i, j + 1)]);
      const k = j % 2 ? i + 1 : i - 1;
      if (k >= 0 && k < nx) edges.push([at(i, j), at(k, j + 1)]);
    }
  }
  return { dim: 2, positions, edges };
}

// A network is checked whole before it replaces the drawing: a bad file leaves the page as it was.
function useNetwork(frame, name) {
  if (!frame || frame.dim !== 2 || !Array.isArray(frame.positions) || !Array.isArray(frame.edges)) {
    throw new Error("a network is a 2D frame: {\"dim\": 2, \"positions\": [...], \"edges\": [...]}.");
  }
  const n = frame.positions.length;
  const bad = frame.positions.findIndex((p) => !Array.isArray(p) || p.length !== 2 || !p.every(Number.isFinite));
  if (bad >= 0) throw new Error(`position ${bad} is not two finite numbers [x, y].`);
  const wrong = frame.edges.findIndex((e) => !Array.isArray(e) || e.length !== 2 || e[0] === e[1]
                                            || !e.every((i) => Number.isInteger(i) && i >= 0 && i < n));
  if (wrong >= 0) throw new Error(`edge ${wrong} is not two different node indices from 0 to ${n - 1}.`);
  clearSketch();
  // No longer the example chosen before: its name and description go, the network's name comes.
  $("example").value = "";
  $("example-text").textContent = "";
  $("name").value = name;
  state.network = { dim: 2, positions: frame.positions, edges: frame.edges };
  $("hint").textContent = "Click nodes of the network to make them source or target sites (choose below); drag from a site to set its motion.";
  edited();
  say(`network: ${n} nodes, ${frame.edges.length} bars; click its nodes to make them sites.`);
}

function addMotion() {
  state.motions.push(state.nodes.map(() => [0, 0]));
  state.motion = state.motions.length - 1;
  el("option", { value: state.motion }, $("motion-index"), true).textContent = String(state.motion + 1);
  $("motion-index").value = String(state.motion);
  edited();
}

function undo() {
  if (state.placed.length) { state.placed.pop(); draw(); return; }
  if (!state.nodes.length) return;
  state.nodes.pop();
  state.motions.forEach((m) => m.pop());
  edited();
}

async function loadExamples() {
  const select = $("example");
  const examples = await (await api("GET", "/v1/examples")).json();
  state.examples = Object.fromEntries(examples.map((e) => [e.name, e.description]));
  state.exampleEndpoints = Object.fromEntries(examples.map((e) => [e.name, e.endpoint]));
  for (const { name, description } of examples) {
    el("option", { value: "example:" + name, title: description }, select, true).textContent = name;
  }
  for (const [name, preset] of Object.entries(PRESETS)) {
    el("option", { value: "preset:" + name, title: preset.description }, select, true).textContent = name;
  }
}

async function pickExample() {
  const value = $("example").value;
  if (!value) return;
  const [kind, name] = [value.slice(0, value.indexOf(":")), value.slice(value.indexOf(":") + 1)];
  if (kind === "preset") {
    const preset = PRESETS[name];
    setKind(preset.kind);
    $("example-text").textContent = preset.description;
    if (preset.kind === "allostery") {
      for (const role of ["source", "target"]) {
        preset[role].positions.forEach((x, i) => { state.nodes.push({ x, role }); state.motions[0].push(preset[role].motion[i]); });
      }
    }
  } else if (state.exampleEndpoints[name] === "/v1/design/multistable") {
    setKind("multistable");
    $("example-text").textContent = state.examples[name];
    await loadConformations(name);
    $("example").value = value;
    return;
  } else {
    const request = await (await api("GET", `/v1/examples/${encodeURIComponent(name)}/request`)).json();
    setKind("draw");
    // The example's options (e.g. n_unspecified of Fig. 3c) go with its drawing until it is cleared.
    state.options = { ...request.options };
    $("example-text").textContent = state.examples[name];
    if (request.dim === 2) {
      state.motions = request.motions.map((m) => m.slice());
      request.positions.forEach((x) => state.nodes.push({ x, role: "specified" }));
      const select = $("motion-index");
      request.motions.slice(1).forEach((_, m) => { el("option", { value: m + 1 }, select, true).textContent = String(m + 2); });
    } else if (request.motions.length === 1) {
      setKind("space3d");
      state.options = { ...request.options };
      $("example-text").textContent = state.examples[name];
      fillTable(request.positions, request.motions[0]);
    } else {
      state.example = request;  // several 3D motions: designed as given, the view turns by dragging
      $("space-text").textContent = "A 3D example with several motions: press Design, then drag the drawing to turn it.";
    }
  }
  $("name").value = name;
  $("example").value = value;
  if (!state.example) edited(); else draw();
}

// ----------------------------------------------------------------------------- wiring

let retrace = null;
for (const b of document.querySelectorAll(".tabs button")) b.addEventListener("click", () => switchTab(b.dataset.kind));
$("canvas").addEventListener("pointerdown", onPointerDown);
$("canvas").addEventListener("pointermove", onPointerMove);
$("canvas").addEventListener("pointerup", onPointerUp);
$("canvas").addEventListener("pointercancel", onPointerUp);
$("example").addEventListener("change", () => pickExample().catch((e) => say(e.message, true)));
$("design").addEventListener("click", design);
$("refine").addEventListener("click", refine);
$("certify").addEventListener("click", certify);
$("slider").addEventListener("input", draw);
$("play").addEventListener("click", play);
$("undo").addEventListener("click", undo);
$("clear").addEventListener("click", clearSketch);
$("add-motion").addEventListener("click", addMotion);
$("network-sheet").addEventListener("click", () => useNetwork(triangulatedSheet(NETWORK, NETWORK_SPACING), "allosteric_sheet"));
$("network-file").addEventListener("change", async () => {
  const file = $("network-file").files[0];
  if (!file) return;
  try {
    const doc = JSON.parse(await file.text());
    useNetwork(doc.frame || doc, `${file.name.replace(/\.json$/i, "")}_sites`);
  } catch (e) {
    say(`${file.name}: ${e.message}`, true);
  }
  $("network-file").value = "";
});
$("clear-placed").addEventListener("click", () => { state.placed = []; clearDesign(); describeSpaces(); });
$("add-row").addEventListener("click", () => {
  const last = state.nodes.length ? state.nodes[state.nodes.length - 1].x : [0, 0, 0];
  state.nodes.push({ x: [last[0] + 1, last[1], last[2]], role: "specified" });
  state.motions[0].push([0, 0, 0]);
  renderTable();
  edited();
});
$("mode-select").addEventListener("change", () => { stop(); state.mode = Number($("mode-select").value); traceMotion(); });
$("motion-index").addEventListener("change", () => { state.motion = Number($("motion-index").value); draw(); });
$("add-node-ms").addEventListener("click", () => {
  state.conformations.forEach((c) => { const last = c[c.length - 1]; c.push([last[0] + 0.5, last[1]]); });
  renderConformations();
  edited();
});
$("n-conformations").addEventListener("change", conformationCount);
$("chain-example").addEventListener("change", () => pickChainExample($("chain-example").value));
for (const radio of document.querySelectorAll("input[name=chain-source]")) {
  radio.addEventListener("change", () => {
    for (const p of document.querySelectorAll("[data-source]")) p.hidden = p.dataset.source !== chainSource();
    if (chainSource() === "given") $("name").value = "two_triangle_module";
    clearDesign();
  });
}
$("soliton").addEventListener("change", () => { solitonForm(); clearDesign(); });
$("add-feature").addEventListener("click", () => {
  if (state.features.length >= 4) { say("at most four features, met together by one module.", true); return; }
  state.features.push({ kind: "fixed_point", d: 1.5, slope: 0.5 });
  renderFeatures();
  clearDesign();
});
$("raw-toggle").addEventListener("change", () => { $("raw").hidden = !$("raw-toggle").checked; });
$("amplitude").addEventListener("input", () => {
  $("amplitude-text").textContent = Number($("amplitude").value).toFixed(2);
  clearTimeout(retrace);
  retrace = setTimeout(() => { stop(); traceMotion(); }, 250);
});
// A key given after the examples were refused (401 at start-up) lists them then.
$("apikey").addEventListener("change", () => {
  if (!state.examples) loadExamples().then(() => say("examples listed."), (e) => say(e.message, true));
});
setKind("draw");
loadExamples().catch((e) => say(e.message, true));
