// The solution space of one unspecified node joined to k specified nodes (the paper's Eqs. 4–6),
// computed in the browser: plain JavaScript, no dependencies, small dense linear algebra.
//
// A node at p with motion v joined to specified node i (position x_i, motion u_i) keeps the bar's
// length to first order iff (x_i − p)·(u_i − v) = 0. With c = p·v the k conditions are linear in
// z = (p, v, c) ∈ R^(2d+1):  Ã z = b,  Ã's row i = [u_iᵀ, x_iᵀ, −1],  b_i = x_i·u_i  (Eq. 4).
// Its solutions are z = W̃ α̃, W̃ = [w_1 … w_m, z*] (a null-space basis of Ã and one particular
// solution), α̃ = (α, 1) (Eq. 5); c = p·v is then the quadric α̃ᵀ Q α̃ = 0 (Eq. 6). The set is
// points (m = 1), a conic (m = 2), ...; none when b ∉ R(Ã) or the quadric has no real points.
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

  function centreAndRms(points) {
    const d = points[0].length, k = points.length;
    const c = Array.from({ length: d }, (_, a) => points.reduce((s, p) => s + p[a], 0) / k);
    const r = Math.sqrt(points.reduce((s, p) => s + p.reduce((t, v, a) => t + (v - c[a]) ** 2, 0), 0) / k);
    return [c, r > 0 ? r : 1];
  }

  // The space for positions x_S (k×d) and motions u_S (k×d). Returns
  // {dim, k, nullity, rank, kind, reason, points: [{position, motion}], curves: [[p, …], …],
  //  basis W̃ and quadric Q of the normalised problem}; kind is "points", "conic", "line",
  // "plane" (every position in 2D: k ≤ 2, or arrows that move the nodes rigidly), "surface"
  // (3D, m ≥ 3) or "none" with a reason.
  function compute(positions, motions) {
    const k = positions.length, d = positions[0].length, n = 2 * d + 1;
    const [cx, sx] = centreAndRms(positions), [cu, su] = centreAndRms(motions);
    const x = positions.map((p) => p.map((v, a) => (v - cx[a]) / sx));
    const u = motions.map((p) => p.map((v, a) => (v - cu[a]) / su));
    const A = x.map((xi, i) => [...u[i], ...xi, -1]);
    const b = x.map((xi, i) => dot(xi, u[i]));
    const { sigma, V, AV } = svd(A, n);
    const top = Math.max(...sigma);
    const live = sigma.map((s) => s > RANK_TOL * top);
    const column = (j) => V.map((r) => r[j]);
    // z* = Σ_{σ_j > 0} v_j (A v_j)ᵀ b / σ_j²: the least-norm solution.
    const zstar = new Array(n).fill(0);
    sigma.forEach((s, j) => {
      if (!live[j]) return;
      const coef = AV.reduce((t, r, i) => t + r[j] * b[i], 0) / (s * s);
      for (let i = 0; i < n; i++) zstar[i] += coef * V[i][j];
    });
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
    const out = { dim: d, k, nullity: m, rank: n - m, basis, quadric: Q, points: [], curves: [], kind: "none", reason: "" };
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
    if (m === 2) return onConic(out, Q, qnorm, sample, (p) => p.map((v, a) => (v - cx[a]) / sx));
    out.kind = d === 2 ? "plane" : "surface";
    out.reason = d === 2 ? `with ${k} specified node${k === 1 ? "" : "s"} every position has a motion (a ${m - 1}-dimensional set); place a third.`
      : `a ${m - 1}-dimensional quadric in (x_U, u_U), not drawn; five specified nodes in general position give a curve.`;
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
  function onConic(out, Q, qnorm, sample, normalised) {
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
    const g = [A[0][0] * base[0] + A[0][1] * base[1] + beta[0], A[1][0] * base[0] + A[1][1] * base[1] + beta[1]];
    // The conic's point on the line at angle φ through α₀ (null at infinity or beyond FAR).
    const at = (phi) => {
      const e = [Math.cos(phi), Math.sin(phi)];
      const eAe = e[0] * (A[0][0] * e[0] + 2 * A[0][1] * e[1]) + A[1][1] * e[1] * e[1];
      const s = Math.abs(eAe) > 1e-14 * qnorm ? -2 * dot(e, g) / eAe : Infinity;
      const al = [base[0] + s * e[0], base[1] + s * e[1]];
      return Number.isFinite(s) && Math.hypot(...al) <= FAR ? sample([...al, 1]).position : null;
    };
    // Uniform in φ, then halved where a chord is longer than MAX_CHORD (normalised units) within
    // NEAR of the specified nodes: the pencil crowds its points where the conic is far from α₀
    // and thins them near it.
    const chord = (p, q) => { const [a, b] = [normalised(p), normalised(q)]; return Math.hypot(...a.map((v, i) => v - b[i])); };
    const near = (p) => Math.hypot(...normalised(p)) <= NEAR;
    const refine = (phi0, p0, phi1, p1, depth, into) => {
      if (depth === 0 || chord(p0, p1) <= MAX_CHORD || !(near(p0) || near(p1))) return;
      const mid = (phi0 + phi1) / 2, pm = at(mid);
      if (!pm) return;
      refine(phi0, p0, mid, pm, depth - 1, into);
      into.push(pm);
      refine(mid, pm, phi1, p1, depth - 1, into);
    };
    let curve = [], lastPhi = 0;
    for (let i = 0; i < PENCIL; i++) {
      const phi = Math.PI * i / (PENCIL - 1), p = at(phi);
      if (!p) { if (curve.length > 1) out.curves.push(curve); curve = []; continue; }
      const last = curve[curve.length - 1];
      if (last && chord(p, last) > FAR / 4) { if (curve.length > 1) out.curves.push(curve); curve = []; }
      else if (last) refine(lastPhi, last, phi, p, 12, curve);
      curve.push(p); lastPhi = phi;
    }
    if (curve.length > 1) out.curves.push(curve);
    return out;
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

  return { compute, intersections };
})();
