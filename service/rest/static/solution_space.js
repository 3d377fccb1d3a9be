// The solution space of one unspecified node joined to k specified nodes (the paper's Eqs. 4–6),
// computed in the browser: plain JavaScript, no dependencies, small dense linear algebra.
//
// A node at p with motion v joined to specified node i (position x_i, motion u_i) keeps the bar's
// length to first order iff (x_i − p)·(u_i − v) = 0. With c = p·v the k conditions are linear in
// z = (p, v, c) ∈ R^(2d+1):  Ã z = b,  Ã's row i = [u_iᵀ, x_iᵀ, −1],  b_i = x_i·u_i  (Eq. 4).
// Its solutions are z = W̃ α̃, W̃ = [w_1 … w_m, z*] (a null-space basis of Ã and one particular
// solution), α̃ = (α, 1) (Eq. 5); c = p·v is then the quadric α̃ᵀ Q α̃ = 0 (Eq. 6). The set is
// points (m = 1), a conic (m = 2), a quadric surface (m = 3: four specified nodes in 3D, Fig. 2g),
// ...; none when b ∉ R(Ã) or the quadric has no real points. In 3D, a surface's positions are
// drawn as plane sections (conics) of it, clipped to a box around the specified nodes.
"use strict";

const SolutionSpace = (() => {
  // σ ≤ RANK_TOL·σ_max counts as zero. Inputs are normalised first (centroid 0, RMS radius 1), so
  // rounding leaves ~1e-15; snapped drawings (multiples of 1/16) are decided exactly.
  const RANK_TOL = 1e-9;
  // A quadric coefficient this small relative to ‖Q‖ is zero (degenerate conics, double roots).
  const QUADRIC_TOL = 1e-10;
  // Samples of a conic's pencil of lines, and the size (in normalised units) beyond which a curve
  // is cut: a hyperbola's branches pass through infinity there.
  const PENCIL = 241, FAR = 40, MAX_CHORD = 0.02, NEAR = 6;
  const CURVE = { pencil: PENCIL, chord: MAX_CHORD, near: NEAR };
  // A surface is drawn as SECTIONS parallel plane sections in each of three directions, inside the
  // specified nodes' bounding box grown by BOX_MARGIN of its largest side on every side; each
  // section's pencil has SECTION_PENCIL lines, its chords refined to SECTION_CHORD inside the box.
  const SECTIONS = 9, BOX_MARGIN = 0.3, SECTION_PENCIL = 61, SECTION_CHORD = 0.06;

  const dot = (a, b) => a.reduce((s, v, i) => s + v * b[i], 0);

  // Singular values and right singular vectors of A (rows × n) by one-sided Jacobi (Hestenes):
  // columns of A·V are made orthogonal; σ_j = ‖(A·V)_j‖. Returns {sigma, V (n columns), AV}.
  function svd(A, n) {
    const U = A.map((r) => r.slice());
    const V = Array.from({ length: n }, (_, i) => Array.from({ length: n }, (_, j) => +(i === j)));
    for (let sweep = 0; sweep < 60; sweep++) {
      let rotated = false;
      for (let p = 0; p < n - 1; p++) {
        for (let q = p + 1; q < n; q++) {
          let alpha = 0, beta = 0, gamma = 0;
          for (const r of U) { alpha += r[p] * r[p]; beta += r[q] * r[q]; gamma += r[p] * r[q]; }
          if (Math.abs(gamma) <= 1e-15 * Math.sqrt(alpha * beta) || gamma === 0) continue;
          rotated = true;
          const zeta = (beta - alpha) / (2 * gamma);
          const t = (zeta >= 0 ? 1 : -1) / (Math.abs(zeta) + Math.sqrt(1 + zeta * zeta));
          const c = 1 / Math.sqrt(1 + t * t), s = c * t;
          for (const r of U) { const a = r[p], b = r[q]; r[p] = c * a - s * b; r[q] = s * a + c * b; }
          for (const r of V) { const a = r[p], b = r[q]; r[p] = c * a - s * b; r[q] = s * a + c * b; }
        }
      }
      if (!rotated) break;
    }
    const sigma = Array.from({ length: n }, (_, j) => Math.sqrt(U.reduce((s, r) => s + r[j] * r[j], 0)));
    return { sigma, V, AV: U };
  }

  // The least-norm solution Σ_{σ_j live} v_j (A v_j)ᵀ b / σ_j² from svd(A) ({sigma, V, AV}).
  function leastNorm({ sigma, V, AV }, b, live) {
    const z = new Array(V.length).fill(0);
    sigma.forEach((s, j) => {
      if (!live[j]) return;
      const coef = AV.reduce((t, r, i) => t + r[j] * b[i], 0) / (s * s);
      for (let i = 0; i < V.length; i++) z[i] += coef * V[i][j];
    });
    return z;
  }

  function centreAndRms(points) {
    const d = points[0].length, k = points.length;
    const c = Array.from({ length: d }, (_, a) => points.reduce((s, p) => s + p[a], 0) / k);
    const r = Math.sqrt(points.reduce((s, p) => s + p.reduce((t, v, a) => t + (v - c[a]) ** 2, 0), 0) / k);
    return [c, r > 0 ? r : 1];
  }

  // The space for positions x_S (k×d) and motions u_S (k×d). Returns
  // {dim, k, nullity, rank, kind, reason, points: [{position, motion}], curves: [[p, …], …],
  //  basis W̃ and quadric Q of the normalised problem}; kind is "points", "conic", "line",
  // "plane" (every position in 2D: k ≤ 2, or arrows that move the nodes rigidly), "quadric" (3D,
  // m = 3: a surface, its shape named in `shape`, its position quadric and box in `surface`),
  // "volume" (3D: positions fill space, or on a line for collinear nodes: not drawn) or "none"
  // with a reason.
  function compute(positions, motions) {
    const k = positions.length, d = positions[0].length, n = 2 * d + 1;
    const [cx, sx] = centreAndRms(positions), [cu, su] = centreAndRms(motions);
    const x = positions.map((p) => p.map((v, a) => (v - cx[a]) / sx));
    const u = motions.map((p) => p.map((v, a) => (v - cu[a]) / su));
    const A = x.map((xi, i) => [...u[i], ...xi, -1]);
    const b = x.map((xi, i) => dot(xi, u[i]));
    const decomposition = svd(A, n), { sigma, V } = decomposition;
    const top = Math.max(...sigma);
    const live = sigma.map((s) => s > RANK_TOL * top);
    const column = (j) => V.map((r) => r[j]);
    const zstar = leastNorm(decomposition, b, live);  // z* = Ã⁺b
    const residual = Math.sqrt(A.reduce((t, r, i) => t + (dot(r, zstar) - b[i]) ** 2, 0));
    const nulls = sigma.map((_, j) => j).filter((j) => !live[j]).map(column);
    const m = nulls.length;
    const basis = Array.from({ length: n }, (_, i) => [...nulls.map((w) => w[i]), zstar[i]]);  // W̃
    const toWorld = (z) => ({
      position: z.slice(0, d).map((v, a) => cx[a] + sx * v),
      motion: z.slice(d, 2 * d).map((v, a) => cu[a] + su * v),
    });
    const sample = (alpha) => toWorld(basis.map((row) => dot(row, alpha)));
    // Q = sym(W̃_pᵀ W̃_v) − sym(w̃_c e_lastᵀ): α̃ᵀQα̃ = p·v − c (the last entry of α̃ is 1).
    const Q = Array.from({ length: m + 1 }, (_, i) => Array.from({ length: m + 1 }, (_, j) => {
      let q = 0;
      for (let a = 0; a < d; a++) q += (basis[a][i] * basis[d + a][j] + basis[a][j] * basis[d + a][i]) / 2;
      return q - ((j === m ? basis[2 * d][i] : 0) + (i === m ? basis[2 * d][j] : 0)) / 2;
    }));
    const out = { dim: d, k, nullity: m, rank: n - m, basis, quadric: Q, points: [], curves: [], kind: "none", reason: "",
                  scales: { cx, sx, cu, su }, x, u };
    if (residual > 1e-8 * (1 + Math.hypot(...b))) {
      out.reason = `the ${k} bar conditions contradict each other: b is not in the range of Ã (rank ${n - m}), so no position and motion satisfy them all.`;
      return out;
    }
    const qnorm = Math.sqrt(Q.flat().reduce((s, v) => s + v * v, 0)) || 1;
    // Q's entries are O(‖z*‖²) at most (W̃'s null columns are unit vectors): below this, Q = 0.
    const qzero = QUADRIC_TOL * Math.max(1, Math.hypot(...zstar) ** 2);
    if (m === 0) {
      if (Math.abs(Q[0][0]) <= qzero) {
        out.kind = "points"; out.points = [sample([1])];
      } else out.reason = "the one solution of the linear conditions breaks c = x_U·u_U.";
      return out;
    }
    // Q = 0: every linear solution keeps c = p·v (no arrows yet, a rigid motion, collinear nodes).
    if (m <= 2 && Q.flat().every((v) => Math.abs(v) <= qzero)) return everywhere(out, basis, m, d, sample);
    if (m === 1) return onLine(out, Q, qnorm, sample);
    const normalised = (p) => p.map((v, a) => (v - cx[a]) / sx);
    if (m === 2) return onConic(out, Q, qnorm, sample, normalised);
    if (m === 3 && d === 3 && Q.flat().some((v) => Math.abs(v) > qzero)) return onQuadric(out, Q);
    out.kind = d === 2 ? "plane" : "volume";
    out.reason = d === 2 ? `with ${k} specified node${k === 1 ? "" : "s"} every position has a motion (a ${m - 1}-dimensional set); place a third.`
      : m === 3 ? "c = x_U·u_U holds on every linear solution (as for a rigid motion of the specified nodes): every position has a motion."
      : `a ${m - 1}-dimensional quadric in (x_U, u_U): its positions fill space, not drawn; four specified nodes in general position give a surface.`;
    return out;
  }

  // Q = 0: every α ∈ R^m solves, and the positions are the image of p(α) = P α + p*, P the
  // position rows of the null basis (unit columns): a point, a line or (2D) every position.
  function everywhere(out, basis, m, d, sample) {
    const { sigma, V } = svd(basis.slice(0, d).map((row) => row.slice(0, m)), m);
    const along = sigma.map((s, j) => [s, j]).filter(([s]) => s > RANK_TOL).map(([, j]) => V.map((r) => r[j]));
    const at = (alpha) => sample([...alpha, 1]);
    if (!along.length) {
      out.kind = "points"; out.points = [at(new Array(m).fill(0))];
    } else if (along.length === 1) {
      out.kind = "line";
      out.curves = [[-FAR, FAR].map((t) => at(along[0].map((v) => t * v)).position)];
    } else {
      out.kind = "plane";
      out.reason = d === 2 ? `every position has a motion: the ${out.k} bar conditions leave the new node free (its motion follows its position).`
        : "a plane of positions, each with a motion; not drawn.";
    }
    return out;
  }

  // m = 1: Q₀₀α² + 2Q₀₁α + Q₁₁ = 0 on the line of linear solutions.
  function onLine(out, Q, qnorm, sample) {
    const [a, h, c] = [Q[0][0], Q[0][1], Q[1][1]];
    const tiny = QUADRIC_TOL * qnorm;
    if (Math.abs(a) <= tiny && Math.abs(h) <= tiny) {
      if (Math.abs(c) <= tiny) {
        out.kind = "line";
        out.curves = [[-FAR, FAR].map((t) => sample([t, 1]).position)];
      } else out.reason = "the line of linear solutions is parallel to the quadric c = x_U·u_U and misses it.";
      return out;
    }
    const roots = quadraticRoots(a, 2 * h, c, tiny);
    if (!roots.length) {
      out.reason = "the line of linear solutions misses the quadric c = x_U·u_U (negative discriminant): no real position.";
      return out;
    }
    out.kind = "points";
    out.points = roots.map((t) => sample([t, 1]));
    return out;
  }

  function quadraticRoots(a, b, c, tiny) {
    if (Math.abs(a) <= tiny) return Math.abs(b) <= tiny ? [] : [-c / b];
    const disc = b * b - 4 * a * c;
    if (disc < -tiny * Math.max(b * b, Math.abs(4 * a * c), tiny)) return [];
    const r = Math.sqrt(Math.max(disc, 0));
    const q = -(b + (b >= 0 ? r : -r)) / 2;  // no cancellation
    return disc <= 0 ? [-b / (2 * a)] : [q / a, c / q];
  }

  // Eigenvalues and unit eigenvectors of the symmetric 2×2 [[a, h], [h, c]].
  function eigen2(a, h, c) {
    const mean = (a + c) / 2, rad = Math.hypot((a - c) / 2, h);
    const theta = 0.5 * Math.atan2(2 * h, a - c);
    return [[mean + rad, [Math.cos(theta), Math.sin(theta)]], [mean - rad, [-Math.sin(theta), Math.cos(theta)]]];
  }

  // m = 2: the conic α̃ᵀQα̃ = 0, α ∈ R² (in 3D its image is a curve in a plane, Fig. 2e), drawn through a pencil of lines from a point α₀ on
  // it: the line α₀ + s·e meets the conic again at s = −2eᵀ(Aα₀ + β)/(eᵀAe), A = Q[:2,:2], β = Q[:2,2].
  function onConic(out, Q, qnorm, sample, normalised, detail = CURVE) {
    const A = [[Q[0][0], Q[0][1]], [Q[1][0], Q[1][1]]], beta = [Q[0][2], Q[1][2]], gamma = Q[2][2];
    const tiny = QUADRIC_TOL * qnorm;
    const f = (al) => al[0] * (A[0][0] * al[0] + 2 * A[0][1] * al[1]) + A[1][1] * al[1] * al[1] + 2 * dot(beta, al) + gamma;
    const [[l1, e1], [l2, e2]] = eigen2(A[0][0], A[0][1], A[1][1]);
    const lines = [];  // degenerate conics: [point, direction]
    let base = null;
    const det = l1 * l2;
    if (Math.abs(det) > tiny * qnorm) {
      const centre = [-(A[1][1] * beta[0] - A[0][1] * beta[1]) / det, -(-A[1][0] * beta[0] + A[0][0] * beta[1]) / det];
      const fc = f(centre);
      if (Math.abs(fc) <= tiny) {
        if (l1 * l2 < 0) {  // two lines crossing at the centre: eᵀAe = 0
          const [p, q] = [Math.sqrt(Math.abs(l2)), Math.sqrt(Math.abs(l1))];
          for (const sgn of [1, -1]) lines.push([centre, [p * e1[0] + sgn * q * e2[0], p * e1[1] + sgn * q * e2[1]]]);
        } else { out.kind = "points"; out.points = [sample([...centre, 1])]; return out; }
      } else {
        for (const [l, e] of [[l1, e1], [l2, e2]]) {
          if (-fc / l >= 0) { const t = Math.sqrt(-fc / l); base = [centre[0] + t * e[0], centre[1] + t * e[1]]; break; }
        }
        if (!base) { out.reason = "the conic is an imaginary ellipse: it has no real points."; return out; }
      }
    } else if (Math.max(Math.abs(l1), Math.abs(l2)) <= tiny) {
      // A = 0: the line 2β·α + γ = 0 (a plane section along a surface's ruling direction).
      const b2 = dot(beta, beta);
      if (b2 <= tiny * tiny) { out.reason = "the conic has no quadratic or linear part: no curve."; return out; }
      lines.push([[-gamma * beta[0] / (2 * b2), -gamma * beta[1] / (2 * b2)], [-beta[1], beta[0]]]);
    } else {
      // A singular: a parabola, two parallel lines, or one line.
      const [[lam, e], [, nvec]] = Math.abs(l1) >= Math.abs(l2) ? [[l1, e1], [l2, e2]] : [[l2, e2], [l1, e1]];
      const bn = dot(beta, nvec), be = dot(beta, e);
      if (Math.abs(bn) > tiny) {  // parabola: on the axis line s = 0, 2(β·n)t + γ = 0
        const t = -gamma / (2 * bn);
        base = [t * nvec[0], t * nvec[1]];
      } else {
        const roots = Math.abs(lam) > tiny ? quadraticRoots(lam, 2 * be, gamma, tiny) : quadraticRoots(0, 2 * be, gamma, tiny);
        if (!roots.length) { out.reason = "the conic is a pair of imaginary parallel lines: no real points."; return out; }
        for (const s of roots) lines.push([[s * e[0], s * e[1]], nvec]);
      }
    }
    out.kind = "conic";
    if (lines.length) {
      out.curves = lines.map(([p, dir]) => {
        const norm = Math.hypot(...dir);
        return [-FAR, FAR].map((t) => sample([p[0] + t * dir[0] / norm, p[1] + t * dir[1] / norm, 1]).position);
      });
      out.degenerate = true;
      return out;
    }
    if (detail.centred) {
      // The pencil's base near α = 0 (a section's box centre): the crossing nearest 0 of the conic
      // with eight lines through 0, t² eᵀAe + 2t β·e + γ = 0 — else a conic far larger than the box
      // is seen from a base far away, and its part in the box falls between the pencil's lines.
      let nearest = Infinity;
      for (let i = 0; i < 8; i++) {
        const e = [Math.cos(Math.PI * i / 8), Math.sin(Math.PI * i / 8)];
        const eAe = e[0] * (A[0][0] * e[0] + 2 * A[0][1] * e[1]) + A[1][1] * e[1] * e[1];
        for (const t of quadraticRoots(eAe, 2 * dot(beta, e), gamma, tiny)) {
          if (Math.abs(t) < nearest) { nearest = Math.abs(t); base = [t * e[0], t * e[1]]; }
        }
      }
    }
    const g = [A[0][0] * base[0] + A[0][1] * base[1] + beta[0], A[1][0] * base[0] + A[1][1] * base[1] + beta[1]];
    // The conic's point on the line at angle φ through α₀ (null at infinity or beyond FAR).
    const at = (phi) => {
      const e = [Math.cos(phi), Math.sin(phi)];
      const eAe = e[0] * (A[0][0] * e[0] + 2 * A[0][1] * e[1]) + A[1][1] * e[1] * e[1];
      const s = Math.abs(eAe) > 1e-14 * qnorm ? -2 * dot(e, g) / eAe : Infinity;
      const al = [base[0] + s * e[0], base[1] + s * e[1]];
      return Number.isFinite(s) && Math.hypot(al[0], al[1]) <= FAR ? sample([al[0], al[1], 1]).position : null;
    };
    // Uniform in φ, then halved where a chord is longer than MAX_CHORD (normalised units) within
    // NEAR of the specified nodes: the pencil crowds its points where the conic is far from α₀
    // and thins them near it.
    // (Plain loops: these run for every sample, thousands per surface.)
    const chord = (p, q) => {
      const a = normalised(p), b = normalised(q);
      let s = 0;
      for (let i = 0; i < a.length; i++) s += (a[i] - b[i]) ** 2;
      return Math.sqrt(s);
    };
    const near = (p) => { const a = normalised(p); let s = 0; for (const v of a) s += v * v; return s <= detail.near ** 2; };
    const refine = (phi0, p0, phi1, p1, depth, into) => {
      if (depth === 0 || chord(p0, p1) <= detail.chord || !(near(p0) || near(p1))) return;
      const mid = (phi0 + phi1) / 2, pm = at(mid);
      if (!pm) return;
      refine(phi0, p0, mid, pm, depth - 1, into);
      into.push(pm);
      refine(mid, pm, phi1, p1, depth - 1, into);
    };
    let curve = [], lastPhi = 0;
    for (let i = 0; i < detail.pencil; i++) {
      const phi = Math.PI * i / (detail.pencil - 1), p = at(phi);
      if (!p) { if (curve.length > 1) out.curves.push(curve); curve = []; continue; }
      const last = curve[curve.length - 1];
      if (last && chord(p, last) > FAR / 4) { if (curve.length > 1) out.curves.push(curve); curve = []; }
      else if (last) refine(lastPhi, last, phi, p, 12, curve);
      curve.push(p); lastPhi = phi;
    }
    if (curve.length > 1) out.curves.push(curve);
    return out;
  }

  // Tᵀ S T for S (n×n) and T (n×r): S in the coordinates T maps from.
  function congruence(S, T) {
    const r = T[0].length, ST = S.map((row) => Array.from({ length: r }, (_, j) => row.reduce((t, v, i) => t + v * T[i][j], 0)));
    return Array.from({ length: r }, (_, i) => Array.from({ length: r }, (_, j) => T.reduce((t, row, a) => t + row[i] * ST[a][j], 0)));
  }

  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const unit = (a) => { const l = Math.hypot(...a); return a.map((v) => v / l); };

  // Eigenvalues and unit eigenvectors [[λ, e], …] of a symmetric 3×3 S (cyclic Jacobi rotations).
  function eigenSym(S) {
    const a = S.map((r) => r.slice()), E = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    for (let sweep = 0; sweep < 50 && Math.hypot(a[0][1], a[0][2], a[1][2]) > 1e-17 * Math.hypot(...a.flat()); sweep++) {
      for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) {
        if (a[p][q] === 0) continue;
        const theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        const t = (theta >= 0 ? 1 : -1) / (Math.abs(theta) + Math.sqrt(1 + theta * theta));
        const c = 1 / Math.sqrt(1 + t * t), s = t * c;
        const turn = (m, k, i, j) => { const [x, y] = [m(k, i), m(k, j)]; return [c * x - s * y, s * x + c * y]; };
        for (let k = 0; k < 3; k++) [a[k][p], a[k][q]] = turn((r, i) => a[r][i], k, p, q);
        for (let k = 0; k < 3; k++) [a[p][k], a[q][k]] = turn((r, i) => a[i][r], k, p, q);
        for (let k = 0; k < 3; k++) [E[k][p], E[k][q]] = turn((r, i) => E[r][i], k, p, q);
      }
    }
    return [0, 1, 2].map((i) => [a[i][i], E.map((r) => r[i])]);
  }

  // The segment a→b inside the box [lo, hi] (Liang–Barsky), or null.
  function clipSegment(a, b, lo, hi) {
    let t0 = 0, t1 = 1;
    for (let i = 0; i < 3; i++) {
      const d = b[i] - a[i];
      for (const [num, den] of [[lo[i] - a[i], d], [a[i] - hi[i], -d]]) {
        if (den === 0) { if (num > 0) return null; continue; }
        const t = num / den;
        if (den > 0) t0 = Math.max(t0, t); else t1 = Math.min(t1, t);
      }
    }
    return t0 <= t1 ? [t0, t1].map((t) => a.map((v, i) => v + t * (b[i] - v))) : null;
  }

  // The parts inside the box of straight lines (two points each: rulings of the surface, cut
  // exactly at the box) and of curves (their points outside dropped: each kept point is on the
  // surface).
  function clipCurves(lines, curves, lo, hi) {
    const inside = (p) => p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && p[2] >= lo[2] && p[2] <= hi[2];
    const out = lines.map(([a, b]) => clipSegment(a, b, lo, hi)).filter(Boolean);
    for (const c of curves) {
      let run = [];
      for (const p of c) {
        if (inside(p)) { run.push(p); continue; }
        if (run.length > 1) out.push(run);
        run = [];
      }
      if (run.length > 1) out.push(run);
    }
    return out;
  }

  // m = 3 in 3D (four specified nodes, Fig. 2g): α = (α₁, α₂, α₃) on the quadric α̃ᵀQα̃ = 0 and the
  // position p = P α + p₀ (P, p₀: W̃'s position rows). With P invertible the positions are the
  // quadric p̃ᵀ Q_p p̃ = 0, Q_p = Tᵀ Q T, T = [[P⁻¹, −P⁻¹p₀], [0, 1]] (normalised coordinates); with
  // P of rank 2 (coplanar specified nodes: a null vector moves only (u_U, c)) every linear
  // solution's position lies in one plane, and each point of it off the nodes' plane has one motion.
  // Drawn as conic sections (onConic) in three families of parallel planes, clipped to a box.
  function onQuadric(out, Q) {
    const P = [0, 1, 2].map((a) => out.basis[a].slice(0, 3)), p0 = [0, 1, 2].map((a) => out.basis[a][3]);
    const { sigma, V, AV } = svd(P, 3), top = Math.max(...sigma), live = sigma.map((s) => s > RANK_TOL * top);
    let Qp;
    if (live.every(Boolean)) {
      const Pinv = [0, 1, 2].map((i) => [0, 1, 2].map((a) => sigma.reduce((t, s, j) => t + V[i][j] * AV[a][j] / (s * s), 0)));
      Qp = congruence(Q, [...Pinv.map((r) => [...r, -dot(r, p0)]), [0, 0, 0, 1]]);
    } else if (live.filter(Boolean).length === 2) {
      const [a, b] = [0, 1, 2].filter((j) => live[j]).map((j) => AV.map((r) => r[j]));
      const n = unit(cross(a, b));
      Qp = [[0, 0, 0, n[0] / 2], [0, 0, 0, n[1] / 2], [0, 0, 0, n[2] / 2], [n[0] / 2, n[1] / 2, n[2] / 2, -dot(n, p0)]];
    } else {
      out.kind = "volume";
      out.reason = "the linear solutions' positions lie on a line (collinear specified nodes): not drawn.";
      return out;
    }
    const qn = Math.hypot(...Qp.flat());
    Qp = Qp.map((r) => r.map((v) => v / qn));
    const [shape, plane, axes] = classify(Qp);
    out.shape = shape;
    if (!axes && !plane) {
      out.reason = `the quadric of positions is ${shape}: no real surface.`;
      return out;
    }
    // The box: the specified nodes' bounding box grown by BOX_MARGIN of its largest side.
    const lo = [0, 1, 2].map((a) => Math.min(...out.x.map((p) => p[a]))), hi = [0, 1, 2].map((a) => Math.max(...out.x.map((p) => p[a])));
    const margin = BOX_MARGIN * Math.max(...hi.map((v, a) => v - lo[a]));
    lo.forEach((_, a) => { lo[a] -= margin; hi[a] += margin; });
    const corners = [0, 1, 2, 3, 4, 5, 6, 7].map((c) => [0, 1, 2].map((a) => ((c >> a) & 1 ? hi[a] : lo[a])));
    const radius = Math.max(...corners.map((c) => Math.hypot(...c)));
    const along = (e) => { const t = corners.map((c) => dot(c, e)); return [Math.min(...t), Math.max(...t)]; };
    const levels = ([s0, s1]) => Array.from({ length: SECTIONS }, (_, i) => s0 + (i + 0.5) * (s1 - s0) / SECTIONS);
    const lines = [], curves = [];
    if (plane) {  // a grid of lines in the plane n·p = h
      const [n, h] = plane, f = unit(cross(n, Math.abs(n[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0])), g = cross(n, f);
      for (const [e1, e2] of [[f, g], [g, f]]) {
        for (const s of levels(along(e1))) {
          const c = [0, 1, 2].map((a) => h * n[a] + s * e1[a]);
          lines.push([-FAR, FAR].map((t) => c.map((v, a) => v + t * e2[a])));
        }
      }
    } else {
      for (const [e, f, g] of axes) {
        for (const s of levels(along(e))) {
          // p = s·e + a·f + b·g: the section's conic in (a, b).
          const H = [0, 1, 2].map((i) => [f[i], g[i], s * e[i]]).concat([[0, 0, 1]]);
          const C = congruence(Qp, H), section = { points: [], curves: [], kind: "none" };
          onConic(section, C, Math.hypot(...C.flat()), (al) => ({ position: [0, 1, 2].map((i) => al[0] * f[i] + al[1] * g[i] + s * e[i]) }),
                  (p) => p, { pencil: SECTION_PENCIL, chord: SECTION_CHORD, near: radius, centred: true });
          (section.degenerate ? lines : curves).push(...section.curves);
        }
      }
    }
    const { cx, sx } = out.scales;
    out.kind = "quadric";
    out.surface = { Q: Qp, lo, hi };
    out.box = [lo, hi].map((c) => c.map((v, a) => cx[a] + sx * v));  // world corners
    out.curves = clipCurves(lines, curves, lo, hi).map((c) => c.map((p) => p.map((v, a) => cx[a] + sx * v)));
    if (!out.curves.length) out.reason = "it does not pass through the box around the specified nodes.";
    return out;
  }

  // The kind of the quadric p̃ᵀ Q_p p̃ = 0 (‖Q_p‖ = 1) from the eigen-decomposition of its 3×3
  // block A and the completed square: [name, plane [n, h] when it is one plane n·p = h, axes
  // [[e, f, g], …]: the normals e of the three section families (with their planes' f, g) when
  // it has real points to draw].
  function classify(Qp) {
    const A = Qp.slice(0, 3).map((r) => r.slice(0, 3)), beta = Qp.slice(0, 3).map((r) => r[3]);
    const eig = eigenSym(A).sort((p, q) => Math.abs(q[0]) - Math.abs(p[0]));
    const nonzero = eig.filter(([l]) => Math.abs(l) > QUADRIC_TOL), zero = eig.filter(([l]) => Math.abs(l) <= QUADRIC_TOL);
    const gamma = Qp[3][3] - nonzero.reduce((t, [l, e]) => t + dot(beta, e) ** 2 / l, 0);
    const linear = zero.find(([, e]) => Math.abs(dot(beta, e)) > QUADRIC_TOL);
    const flat = Math.abs(gamma) <= QUADRIC_TOL;
    const positive = nonzero.filter(([l]) => l * -gamma > 0).length, mixed = new Set(nonzero.map(([l]) => Math.sign(l))).size > 1;
    // Sections perpendicular to each eigenvector, the odd one first (the one of another sign, or
    // of λ = 0, or the longest axis: its sections are the surface's ellipses or parabolas). With
    // two zero eigenvalues (a parabolic cylinder, parallel planes) the eigenvectors of λ = 0 are
    // turned so that the odd one is perpendicular to β (a ruling) and the next one along β.
    let odd = zero.length ? zero[0][1] : (nonzero.find(([l]) => nonzero.filter(([m]) => Math.sign(m) === Math.sign(l)).length === 1) || eig[2])[1];
    let rest = eig.map(([, e]) => e).filter((e) => e !== odd);
    if (zero.length === 2) {
      const [[, z1], [, z2]] = zero, [b1, b2] = [dot(beta, z1), dot(beta, z2)], bn = Math.hypot(b1, b2);
      const [c, s] = bn > QUADRIC_TOL ? [b1 / bn, b2 / bn] : [0, 1];
      odd = z1.map((v, i) => s * v - c * z2[i]);
      rest = [z1.map((v, i) => c * v + s * z2[i]), nonzero[0][1]];
    }
    const axes = [[odd, rest[0], rest[1]], [rest[0], rest[1], odd], [rest[1], odd, rest[0]]];
    const n = nonzero.length;
    if (n === 0) return linear ? ["a plane", [unit(beta), -Qp[3][3] / (2 * Math.hypot(...beta))], null] : ["empty", null, null];
    if (n === 1 && !linear && flat) { const [l, e] = nonzero[0]; return ["a plane", [e, -dot(beta, e) / l], null]; }
    if (n === 1) return linear ? ["a parabolic cylinder", null, axes] : positive ? ["a pair of parallel planes", null, axes] : ["a pair of imaginary parallel planes", null, null];
    if (n === 2 && linear) return [mixed ? "a hyperbolic paraboloid" : "an elliptic paraboloid", null, axes];
    if (n === 2 && flat) return mixed ? ["a pair of crossing planes", null, axes] : ["an imaginary pair of planes (one real line)", null, null];
    if (n === 2) return [["an imaginary cylinder", "a hyperbolic cylinder", "an elliptic cylinder"][positive], null, positive ? axes : null];
    if (flat) return mixed ? ["a cone", null, axes] : ["an imaginary cone (one real point)", null, null];
    const round = Math.abs(nonzero[0][0] - nonzero[2][0]) <= QUADRIC_TOL * 1e3 * Math.abs(nonzero[0][0]);
    return [["an imaginary ellipsoid", "a hyperboloid of two sheets", "a hyperboloid of one sheet", round ? "a sphere" : "an ellipsoid"][positive],
            null, positive ? axes : null];
  }

  // A surface's point where the ray origin + t·direction (world) first meets it inside its box,
  // or null; for hand placement (the ray through the clicked pixel, from the viewer).
  function hit(space, origin, direction) {
    const { cx, sx } = space.scales, { Q, lo, hi } = space.surface;
    const o = [...origin.map((v, a) => (v - cx[a]) / sx), 1], d = [...unit(direction), 0];
    const form = (a, b) => a.reduce((t, ai, i) => t + ai * dot(Q[i], b), 0);
    const ts = quadraticRoots(form(d, d), 2 * form(d, o), form(o, o), QUADRIC_TOL).sort((a, b) => a - b);
    for (const t of ts) {
      const p = [0, 1, 2].map((a) => o[a] + t * d[a]);
      if (p.every((v, a) => v >= lo[a] && v <= hi[a])) return project(space, p.map((v, a) => cx[a] + sx * v));
    }
    return null;
  }

  // p (world) moved onto a surface by Newton steps along the quadric's gradient, p ← p − q∇q/‖∇q‖²
  // (normalised coordinates): the nearest point to first order, on the surface to rounding.
  function project(space, p) {
    if (!space.surface) return p;
    const { cx, sx } = space.scales, Q = space.surface.Q;
    let z = [...p.map((v, a) => (v - cx[a]) / sx), 1];
    for (let step = 0; step < 8; step++) {
      const Qz = Q.map((r) => dot(r, z)), q = dot(z, Qz), grad = Qz.slice(0, 3).map((v) => 2 * v), g2 = dot(grad, grad);
      if (g2 === 0 || Math.abs(q) <= 1e-17 * g2) break;
      z = [...grad.map((v, a) => z[a] - q * v / g2), 1];
    }
    return z.slice(0, 3).map((v, a) => cx[a] + sx * v);
  }

  // The motion v of a node at p (world) joined to every specified node: (x_i − p)·v = (x_i − p)·u_i
  // solved by least squares on the normalised problem (exact when p is on the space).
  function motionAt(space, p) {
    const { cx, sx, cu, su } = space.scales, q = p.map((v, a) => (v - cx[a]) / sx);
    const rows = space.x.map((xi) => xi.map((v, a) => v - q[a])), rhs = rows.map((r, i) => dot(r, space.u[i]));
    const decomposition = svd(rows, p.length), top = Math.max(...decomposition.sigma);
    const v = leastNorm(decomposition, rhs, decomposition.sigma.map((s) => s > RANK_TOL * top));
    return v.map((w, a) => cu[a] + su * w);
  }

  // Crossing points of two polylines (p, q: lists of curves): where one node sits on both spaces.
  function intersections(curvesA, curvesB) {
    const hits = [];
    for (const a of curvesA) for (const b of curvesB) {
      for (let i = 0; i + 1 < a.length; i++) {
        const [p, r] = [a[i], [a[i + 1][0] - a[i][0], a[i + 1][1] - a[i][1]]];
        for (let j = 0; j + 1 < b.length; j++) {
          const [q, s] = [b[j], [b[j + 1][0] - b[j][0], b[j + 1][1] - b[j][1]]];
          const den = r[0] * s[1] - r[1] * s[0];
          if (den === 0) continue;
          const t = ((q[0] - p[0]) * s[1] - (q[1] - p[1]) * s[0]) / den;
          const w = ((q[0] - p[0]) * r[1] - (q[1] - p[1]) * r[0]) / den;
          if (t >= 0 && t < 1 && w >= 0 && w < 1) hits.push([p[0] + t * r[0], p[1] + t * r[1]]);
        }
      }
    }
    return hits;
  }

  return { compute, intersections, hit, project, motionAt };
})();
