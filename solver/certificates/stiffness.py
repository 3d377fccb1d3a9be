"""The optimal-stiffness margin of a large frame, by a symmetry-reduced interior-point method (or a spectral bundle method), with a verified bracket.

    λ* = max { φ(k) : k ∈ Δ },   φ(k) = λ_min(Pᵀ K(k) P),   K(k) = Cᵀ diag(k) C = Σ_e k_e c_e c_eᵀ,
    Δ = { k ≥ 0, Σ_e k_e = N_B },   P an orthonormal basis of span^⊥ (span = rigid ⊕ designed),

the problem of certificates.rigidity_margin when its LMI (p = dim span^⊥) is too large for a
general SDP solver.  Three exact steps make it small enough for a primal–dual interior-point
method written for its structure (rank-one terms):

1. Symmetry.  A reflection T = A diag(±1) Aᵀ in the principal axes A of the centred nodes
   that maps the nodes onto themselves (permutation π), bars onto bars and span onto itself
   acts on motions by the orthogonal R_T (u ↦ u', u'_{π(i)} = T u_i), with
   K(T·k) = R_T K(k) R_Tᵀ (T·k: k permuted with the bars).  φ is concave and T-invariant, so
   averaging an optimal k over the group G of such reflections (an elementary abelian 2-group,
   |G| ≤ 2^d) keeps it optimal: k may be taken constant on bar orbits, one variable
   y_o = Σ_{e∈o} k_e per orbit.  (Every orthogonal symmetry of the nodes commutes with their
   second moment; when its eigenvalues are distinct it is such a T, so G is then the whole
   point group.  With equal moments the coordinate axes are tried.)
2. Block diagonalisation.  G's irreducible representations are its |G| characters χ (±1); the
   isotypic components E_χ = range (1/|G|) Σ_T χ(T) R_T are orthogonal, invariant under every
   K(k) with k constant on orbits and under span, so span^⊥ = ⊕_χ (E_χ ⊖ span) with bases Q_χ
   (dN × p_χ, Σ p_χ = p), and Pᵀ K(k) P ≅ ⊕_χ Q_χᵀ K(k) Q_χ.  Since R_T c_e = ±c_{T e} and
   R_Tᵀ Q_χ = χ(T) Q_χ, each orbit's part is rank one in every block:
       Q_χᵀ (Σ_{e∈o} c_e c_eᵀ) Q_χ = |o| b_oχ b_oχᵀ,   b_oχ = Q_χᵀ c_{e_o}  (e_o its representative).
3. Homogeneity.  With y_o = |o| k_o (the orbit's share of Σ k), λ* = N_B / τ* with
       τ* = min { Σ_o y_o : Σ_o y_o b_oχ b_oχᵀ ⪰ I for every χ, y ≥ 0 }         (dual form)
          = max { Σ_χ tr X_χ : Σ_χ b_oχᵀ X_χ b_oχ + x_o = 1, X_χ ⪰ 0, x ≥ 0 }  (primal form).

The interior-point method (Mehrotra predictor–corrector, HKM direction; Helmberg, Rendl,
Vanderbei & Wolkowicz 1996) keeps the dual iterate y strictly feasible and solves, per
iteration, one Schur system M Δy = r with M = Σ_χ (B_χ X_χ B_χᵀ) ∘ (B_χ S_χ⁻¹ B_χᵀ) + diag(x/y)
(B_χ: the rows b_oχ; m × m, m = orbits), so the cost is Σ_χ (m² p_χ + m p_χ² + p_χ³).

The certificate is verified outside the method, on the full frame and every bar:
    lower = λ_min(Pᵀ K(k̂) P) at k̂_e = y_o/|o| scaled to Σ k̂ = N_B (eigen.py: the smallest Ritz
            value minus its residual norm), a value some allocation attains;
    upper = U(Y) = N_B · max_e c_eᵀ Y c_e with Y = V Vᵀ / ‖V‖_F², V = ⊕_χ Q_χ X_χ^½ projected
            ⟂ span: for every k ∈ Δ, φ(k) ≤ ⟨K(k), Y⟩ = Σ k_e c_eᵀYc_e ≤ U(Y) (weak duality),
            whatever the iterate's accuracy or feasibility.
Without symmetry (G = {I}) the method is the same with one block of size p.

Frames whose reduced LMI keeps a large block (no symmetry: the 3D chains, p ≈ 2100 in one
block) would spend tens of seconds per interior-point iteration; when one iteration would cost
more than IPM_MAX_FLOPS the route is instead a spectral bundle method (Helmberg & Rendl 2000,
proximal form, maximising), first-order: the model
    φ̂(k) = min( λ_min(Vᵀ K(k) V), ḡᵀ k ) ≥ φ(k)
uses a bundle V (orthonormal, ⟂ span) of eigenvectors met so far and an aggregate ḡ = g(W̄) of
the dropped ones (g_e(W) = c_eᵀ W c_e, the supergradients of φ).  Each iteration solves the
master problem (Clarabel, one variable per bar)
    max_{k ∈ Δ ∩ [k̂/ρ, ρ k̂]}  φ̂(k) − (u/2)‖k − k̂‖²
whose dual (Z ⪰ 0 on the bundle, α ≥ 0 on the aggregate) is a Y for U; evaluates φ at the new
k by sparse shift-invert Lanczos (a serious step moves k̂ there when it realises a fraction of
the predicted increase; a null step enlarges the bundle), and keeps the bundle small: the
dominant part of Z, plus the new point's smallest eigenvectors.  The multiplicative trust region
[k̂/ρ, ρ k̂] keeps every bar alive, so a step cannot make the frame floppy.  Its bracket is
φ(k̂) (the smallest Ritz value minus its residual) ≤ λ* ≤ U(Y), Y = (V Z Vᵀ + α W̄)/(tr Z + α).

Both routes scale the problem so that φ(1) = 1, and stop when (upper − lower)/upper ≤ GAP_RTOL
or after TIME_S seconds (the bundle: BUNDLE_TIME_S; within 80 % of the request's budget): the
bracket is verified either way, and the status says whether the target gap was met.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from zeromode.solver.analysis.eigen import smallest_eigenpairs
from zeromode.solver.analysis.rank import nullspace, orthonormal_range
from zeromode.solver.budget import check_budget, remaining
from zeromode.solver.progress import report_progress
from zeromode.solver.tolerances import (
    AXES_RTOL,
    BUNDLE_RANK_RTOL,
    LANCZOS_RTOL,
    STEP_PRODUCT_MIN,
    SYMMETRY_ATOL,
    SYMMETRY_INVARIANT_RTOL,
)

# Relative gap (U − L)/U at which the bracket is closed.
GAP_RTOL = 1e-3
# Wall time of one optimisation, within the request's budget (budget.py) when there is one;
# the spectral bundle's bracket stalls (a 64-block chain: 6.8 % after 40 s, 6.9 % after 60 s),
# so it stops earlier.
TIME_S = 60.0
BUNDLE_TIME_S = 40.0
# Smallest eigenpairs evaluated for the verified lower bound (the optimum's λ_min is multiple).
EIGENPAIRS = 6
# Blocks larger than this take their step lengths from a Lanczos Ritz value (to LANCZOS_RTOL).
DENSE_STEP = 50
# The interior-point iteration verifies its bracket once its own duality gap is below this
# fraction of GAP_RTOL, stops after MAX_ITERATIONS, and steps this fraction of the way to the
# boundary of the cones; a step whose Cholesky factor fails is shortened by BACKTRACK.
INNER_FRACTION = 0.5
MAX_ITERATIONS = 80
STEP_FRACTION = 0.95
BACKTRACK = 0.5
# The interior-point route runs when one iteration costs at most this many flops, so that its
# 15–20 iterations fit in TIME_S on a loaded core (the 20 × 20 sheet reduced: 3e10 flops,
# 1.6 s at load 2, 16 iterations); beyond it, the spectral bundle route.
IPM_MAX_FLOPS = 5e10
# Smallest eigenpairs evaluated per point (the new cuts) and the bundle's largest size.
BUNDLE_CUTS = 4
BUNDLE_MAX = 10
# Multiplicative trust region of the master: each stiffness within a factor ρ of k̂'s.
TRUST_RATIO = 2.0
# A step is serious when φ rises by this fraction of the model's predicted rise; the proximal
# weight halves after a step that realises VERY_GOOD of it, and doubles after a null step.
SERIOUS = 0.1
VERY_GOOD = 0.7
# Eigenvectors of the master's dual Z below this fraction of its largest weight go to the aggregate.
KEEP_RTOL = 1e-3
# Bundle directions whose energy at k̂ exceeds this (in units of φ(1)) cannot matter to λ_min and
# would only scale the master badly (Lanczos noise orthonormalised into a stiff direction).
SOFT_MAX = 100.0
# Every this many iterations the bound U is also taken from the master without proximal term.
BOUND_EVERY = 10


@dataclass(frozen=True, eq=False)
class Reduction:
    """The LMI of the module docstring reduced by the frame's reflection group.

    signs (|G|, d) and perms (|G|, N): the group elements T (their signs along the principal
    axes) and their node permutations π (no columns for the trivial reduction, built without
    positions);
    bases: one Q_χ (dN × p_χ, orthonormal, ⟂ span) per character with p_χ > 0; orbit (N_B,):
    each bar's orbit index; sizes (m,): |o|; representatives (m,): one bar e_o per orbit."""

    signs: np.ndarray
    perms: np.ndarray
    bases: tuple[np.ndarray, ...]
    orbit: np.ndarray
    sizes: np.ndarray
    representatives: np.ndarray

    def rows(self, c) -> tuple[np.ndarray, ...]:
        """B_χ (m × p_χ), row o = b_oχ = Q_χᵀ c_{e_o}, for C (N_B × dN, sparse)."""
        lead = c[self.representatives]
        return tuple(np.asarray(lead @ q) for q in self.bases)

    def iteration_flops(self) -> float:
        """Floating-point operations of one interior-point iteration on this reduction,
        Σ_χ (2m²p_χ + 6mp_χ² + 20p_χ³): Schur complement, products with B_χ, factorisations
        and step lengths of the p_χ × p_χ blocks."""
        m = float(len(self.sizes))
        return sum(2 * m * m * p + 6 * m * p * p + 20 * p**3 for p in (float(q.shape[1]) for q in self.bases))


@dataclass(frozen=True, eq=False)
class StiffnessResult:
    """lower ≤ λ* ≤ upper (verified); stiffness: k̂ (N_B, Σ = N_B) attaining ``lower``;
    method "interior_point" or "spectral_bundle"; dual: for the interior-point route V (dN × r,
    ⟂ span) with upper = N_B·max_e ‖(C V)_e‖²/‖V‖_F² (C scaled back), None for the bundle's;
    status "optimal" (gap ≤ GAP_RTOL) or "gap_not_closed"; iterations; time_ms; group_order
    |G| and blocks p_χ of the reduction (1 and (p,) for the bundle route)."""

    lower: float
    upper: float
    stiffness: np.ndarray
    method: str
    dual: np.ndarray | None
    status: str
    iterations: int
    time_ms: float
    group_order: int
    blocks: tuple[int, ...]

    @classmethod
    def bracketed(cls, lower: float, upper: float, uniform: float, stiffness: np.ndarray, method: str,
                  dual: np.ndarray | None, iterations: int, t0: float, group_order: int,
                  blocks: tuple[int, ...]) -> StiffnessResult:
        """The result of a route that bracketed λ*/uniform in [lower, upper] (scaled units),
        started at perf_counter ``t0``: "optimal" once the bracket closed to GAP_RTOL."""
        status = "optimal" if upper - lower <= GAP_RTOL * upper else "gap_not_closed"
        return cls(lower * uniform, upper * uniform, stiffness, method, dual, status, iterations,
                   1e3 * (time.perf_counter() - t0), group_order, blocks)


def principal_axes(positions: np.ndarray) -> np.ndarray:
    """Orthonormal axes (d × d, columns) of the centred ``positions`` (N, d): the eigenvectors
    of their second moment, which every symmetry of the nodes preserves — or the coordinate
    axes when two moments agree to AXES_RTOL (the axes are then not determined by the nodes)."""
    x = positions - positions.mean(axis=0)
    moments, axes = np.linalg.eigh(x.T @ x)
    if np.any(np.diff(moments) <= AXES_RTOL * max(moments[-1], 1e-300)):
        return np.eye(positions.shape[1])
    return axes


def sign_symmetries(positions: np.ndarray, edges: np.ndarray, span: np.ndarray):
    """The reflections T = A diag(s) Aᵀ, s ∈ {±1}^d, A the principal axes of the centred
    ``positions`` (N, d), that map nodes to nodes, bars to bars and span (dN × q, orthonormal)
    onto themselves: (A, signs (|G|, d), perms (|G|, N)), the identity first.  They form a group
    (products of symmetries are)."""
    n, d = positions.shape
    axes = principal_axes(positions)
    x = (positions - positions.mean(axis=0)) @ axes  # coordinates along the axes
    tree = cKDTree(x)
    bars = {tuple(e) for e in np.sort(edges, axis=1).tolist()}
    signs, perms = [], []
    for code in range(2**d):
        s = np.array([-1.0 if code >> a & 1 else 1.0 for a in range(d)])
        distance, perm = tree.query(x * s)
        if distance.max() > SYMMETRY_ATOL or np.unique(perm).size != n:
            continue
        if not all(tuple(e) in bars for e in np.sort(perm[edges], axis=1).tolist()):
            continue
        image = np.empty_like(span.reshape(n, d, -1))
        image[perm] = np.einsum("ab,nbq->naq", (axes * s) @ axes.T, span.reshape(n, d, -1))
        image = image.reshape(n * d, -1)
        if np.linalg.norm(image - span @ (span.T @ image)) > SYMMETRY_INVARIANT_RTOL * max(np.linalg.norm(span), 1.0):
            continue
        signs.append(s)
        perms.append(perm)
    return axes, np.array(signs), np.array(perms)


def isotypic_basis(axes: np.ndarray, signs: np.ndarray, perms: np.ndarray, character: np.ndarray) -> sp.csc_matrix:
    """Orthonormal basis (dN × n_χ, sparse) of E_χ = range (1/|G|) Σ_T χ(T) R_T: the
    normalised nonzero vectors Σ_T χ(T) R_T (A_a at node i) for one node i per node orbit and
    every axis A_a (R_T maps A_a at node j to s_a A_a at node π(j); distinct orbits or axes
    give orthogonal columns)."""
    n, d = perms.shape[1], signs.shape[1]
    rows, cols, values = [], [], []
    column = 0
    seen = np.zeros(n, bool)
    for i in range(n):
        if seen[i]:
            continue
        seen[perms[:, i]] = True
        for a in range(d):
            vector = np.zeros(n)
            np.add.at(vector, perms[:, i], character * signs[:, a])
            support = np.flatnonzero(np.abs(vector) > 0.5)  # sums of ±1: 0 or ≥ 1
            if support.size:
                rows.extend((support[:, None] * d + np.arange(d)).ravel())
                cols.extend([column] * (support.size * d))
                values.extend(np.outer(vector[support] / np.linalg.norm(vector[support]), axes[:, a]).ravel())
                column += 1
    return sp.csc_matrix((values, (rows, cols)), shape=(n * d, column))


def reduce_lmi(positions: np.ndarray, edges: np.ndarray, span: np.ndarray) -> Reduction:
    """Steps 1–2 of the module docstring for the frame's ``positions`` (N, d) and ``edges``
    (N_B, 2) (in the coordinates of its C) and span (dN × q, orthonormal)."""
    axes, signs, perms = sign_symmetries(positions, edges, span)
    d = signs.shape[1]
    characters = {tuple(np.prod(signs[:, [a for a in range(d) if subset >> a & 1]], axis=1)) for subset in range(2**d)}
    bases = []
    for character in sorted(characters, reverse=True):
        e = isotypic_basis(axes, signs, perms, np.array(character))
        # The singular values of Eᵀ span are the cosines of the angles between span and E_χ:
        # 1 or 0 as span is invariant (a relative rank decision would misjudge a block that
        # holds none of span, where they are all round-off).
        _, cosines, vt = np.linalg.svd(np.asarray(e.T @ span).T, full_matrices=True)
        q = np.asarray(e @ vt[int(np.sum(cosines > 0.5)) :].T)
        if q.shape[1]:
            bases.append(q - span @ (span.T @ q))
    index = {e: b for b, e in enumerate(map(tuple, np.sort(edges, axis=1).tolist()))}
    images = np.sort(perms[:, edges], axis=2)  # (|G|, N_B, 2)
    orbit = np.full(len(edges), -1)
    representatives = []
    for b in range(len(edges)):
        if orbit[b] < 0:
            orbit[[index[tuple(e)] for e in images[:, b].tolist()]] = len(representatives)
            representatives.append(b)
    sizes = np.bincount(orbit).astype(float)
    return Reduction(signs, perms, tuple(bases), orbit, sizes, np.array(representatives))


def optimal_stiffness(
    c,
    span: np.ndarray,
    uniform: float,
    positions: np.ndarray | None = None,
    edges: np.ndarray | None = None,
    time_s: float = TIME_S,
) -> StiffnessResult:
    """max_k λ_min(Pᵀ Cᵀ diag(k) C P) over Δ for the normalised C (N_B × dN, sparse) and span
    (dN × q orthonormal, P its complement); ``uniform`` = φ(1) > 0; positions (N, d) and edges
    (N_B, 2) of the frame C belongs to, for its symmetry (None: no reduction); at most
    ``time_s`` seconds (and 80 % of what is left of the request's budget).  The interior-point
    route when one of its iterations costs at most IPM_MAX_FLOPS, else the spectral bundle."""
    t0 = time.perf_counter()
    budget = time_s if remaining() is None else min(time_s, 0.8 * remaining())
    scaled = (sp.csr_matrix(c) / np.sqrt(uniform)).tocsr()  # φ(1) = 1 for the scaled rows
    if positions is None:
        reduction = _trivial(scaled.shape[0], span)
    else:
        reduction = reduce_lmi(np.asarray(positions, float), np.asarray(edges), span)
    if reduction.iteration_flops() > IPM_MAX_FLOPS:
        return spectral_bundle(c, span, uniform, min(time_s, BUNDLE_TIME_S))
    best = None
    for y, x, iterations in _interior_point(reduction.rows(scaled), reduction.sizes, t0, budget):
        result = _verify(scaled, span, reduction, y, x)
        best = result if best is None or result[1] - result[0] < best[1] - best[0] else best
        if best[1] - best[0] <= GAP_RTOL * best[1]:
            break
    lower, upper, k, dual = best
    return StiffnessResult.bracketed(lower, upper, uniform, k, "interior_point", dual, iterations, t0,
                                     len(reduction.signs), tuple(q.shape[1] for q in reduction.bases))


def _trivial(n_bars: int, span: np.ndarray) -> Reduction:
    """The reduction by the trivial group: one block P, every bar its own orbit."""
    return Reduction(
        np.ones((1, 1)), np.zeros((1, 0), int), (nullspace(span.T)[0],), np.arange(n_bars), np.ones(n_bars), np.arange(n_bars)
    )


def _verify(scaled, span, reduction: Reduction, y: np.ndarray, x: list[np.ndarray]):
    """(lower, upper, k̂, V) of the module docstring, on the full frame, in scaled units."""
    n_bars = scaled.shape[0]
    k = (y / reduction.sizes)[reduction.orbit]
    k *= n_bars / k.sum()
    lower = lower_of(smallest_eigenpairs(sp.csc_matrix(scaled.T @ sp.diags(k) @ scaled), EIGENPAIRS, deflate=span))
    factors = []
    for q, xj in zip(reduction.bases, x):
        w, u = np.linalg.eigh((xj + xj.T) / 2)
        factors.append(q @ (u * np.sqrt(np.maximum(w, 0.0))))
    v = np.column_stack(factors)
    v -= span @ (span.T @ v)
    energies = np.asarray(scaled @ v) ** 2
    upper = float(n_bars * energies.sum(axis=1).max() / np.sum(v**2))
    return lower, upper, k, v


def _interior_point(rows: tuple[np.ndarray, ...], sizes: np.ndarray, t0: float, budget: float):
    """The primal–dual iteration of the module docstring on the blocks B_χ (m × p_χ), from the
    uniform allocation (y = |o|, scaled to S ⪰ I: ``sizes``); yields
    (y, [X_χ], iterations) whenever its duality gap is below INNER_FRACTION·GAP_RTOL (then
    INNER_FRACTION times that, and so on), and a last time when it stops: time, iteration cap,
    or no further progress in floating point."""
    m = rows[0].shape[0]
    identity = [np.eye(b.shape[1]) for b in rows]
    start = min(la.eigvalsh((b.T * sizes) @ b, subset_by_index=[0, 0])[0] for b in rows)
    y = 2.0 * sizes / start  # S_χ = Σ y_o b_o b_oᵀ − I ⪰ I: strictly feasible
    s = [(b.T * y) @ b - i for b, i in zip(rows, identity)]
    # X_χ = ξ S_χ⁻¹ (centred: X S = ξ I), ξ so that the primal is strictly feasible.
    s_inv = [_inverse(sj) for sj in s]
    leverage = sum(np.sum((b @ si) * b, axis=1) for b, si in zip(rows, s_inv))
    xi = 0.5 / leverage.max()
    x = [xi * si for si in s_inv]
    x_lp = 1.0 - xi * leverage  # ≥ 1/2
    total = sum(b.shape[1] for b in rows) + m
    target = INNER_FRACTION * GAP_RTOL
    iterations = 0
    while True:
        check_budget()
        primal, dual = sum(np.trace(xj) for xj in x), float(y.sum())
        gap = (dual - primal) / dual
        elapsed = time.perf_counter() - t0
        report_progress(min(elapsed / budget, 1.0) if budget > 0 else 1.0, "interior-point iterations")
        if gap <= target:
            yield y, x, iterations
            target *= INNER_FRACTION
        if elapsed > budget or iterations >= MAX_ITERATIONS:
            break
        try:
            step = _newton_step(rows, y, x, x_lp, s, total)
        except la.LinAlgError:  # a factor lost definiteness in round-off: as far as it goes
            break
        if step is None:
            break
        y, x, x_lp, s = step
        iterations += 1
    yield y, x, iterations


def _newton_step(rows, y, x, x_lp, s, total):
    """One Mehrotra predictor–corrector step (HKM direction) from a strictly feasible dual
    (y, S) and a positive primal (X, x_lp); returns the new iterate, or None when the step
    makes no progress."""
    s_inv = [_inverse(sj) for sj in s]
    mu = (sum(np.vdot(xj, sj) for xj, sj in zip(x, s)) + x_lp @ y) / total
    bx = [b @ xj for b, xj in zip(rows, x)]
    bs = [b @ si for b, si in zip(rows, s_inv)]
    schur = np.diag(x_lp / y)
    for b, bxj, bsj in zip(rows, bx, bs):
        schur += (bxj @ b.T) * (bsj @ b.T)
    schur_factor = la.cho_factor(schur, lower=True)
    a_x = sum(np.sum(bxj * b, axis=1) for bxj, b in zip(bx, rows)) + x_lp  # 𝒜(X) without sign
    a_s = [np.sum(bsj * b, axis=1) for bsj, b in zip(bs, rows)]
    residual = a_x - 1.0  # R_p = 𝒜-residual of the primal equalities (−1 − (−𝒜(X)))

    def direction(sigma, correction, a_correction):
        # ΔX = σμS⁻¹ − X − corr − sym(X ΔS S⁻¹), ΔS = Σ Δy_o b_o b_oᵀ, M Δy = R_p − 𝒜(R_c).
        a_rc = sigma * mu * (sum(a_s) + 1.0 / y) - a_x - a_correction
        dy = la.cho_solve(schur_factor, -residual + a_rc)
        ds = [(b.T * dy) @ b for b in rows]
        dx = []
        for xj, dsj, si, cj in zip(x, ds, s_inv, correction):
            t = xj @ dsj @ si
            dx.append(sigma * mu * si - xj - cj - 0.5 * (t + t.T))
        # The slack's step from the primal equalities themselves (rather than from the
        # linearised complementarity, equal in exact arithmetic): round-off in the Schur solve
        # then cannot accumulate into a violation of Σ_χ b_oᵀX_χb_o ≤ 1, which U would pay for.
        dx_lp = -residual - sum(np.sum((b @ dxj) * b, axis=1) for b, dxj in zip(rows, dx))
        return dy, ds, dx, dx_lp

    def lengths(dy, ds, dx, dx_lp):
        primal = min([_boundary(xj, dxj) for xj, dxj in zip(x, dx)] + [_ratio(x_lp, dx_lp)])
        dual = min([_boundary(sj, dsj) for sj, dsj in zip(s, ds)] + [_ratio(y, dy)])
        return primal, dual

    zero = [np.zeros_like(xj) for xj in x]
    dy, ds, dx, dx_lp = direction(0.0, zero, 0.0)
    alpha_p, alpha_d = lengths(dy, ds, dx, dx_lp)
    affine = (
        sum(np.vdot(xj + alpha_p * dxj, sj + alpha_d * dsj) for xj, dxj, sj, dsj in zip(x, dx, s, ds))
        + (x_lp + alpha_p * dx_lp) @ (y + alpha_d * dy)
    ) / total
    sigma = min(1.0, (affine / mu) ** 3)
    correction = []
    a_correction = 0.0
    for b, dxj, dsj, si in zip(rows, dx, ds, s_inv):
        t = dxj @ dsj @ si
        correction.append(0.5 * (t + t.T))
        a_correction = a_correction + np.sum((b @ correction[-1]) * b, axis=1)
    dy, ds, dx, dx_lp = direction(sigma, correction, a_correction + dx_lp * dy / y)
    alpha_p, alpha_d = lengths(dy, ds, dx, dx_lp)
    alpha_p, alpha_d = min(1.0, STEP_FRACTION * alpha_p), min(1.0, STEP_FRACTION * alpha_d)
    if alpha_p * alpha_d == 0.0:
        return None
    while True:  # Ritz values and round-off may leave a factor indefinite at the computed lengths
        new_x = [xj + alpha_p * dxj for xj, dxj in zip(x, dx)]
        new_s = [sj + alpha_d * dsj for sj, dsj in zip(s, ds)]
        if all(_definite(a) for a in new_x + new_s):
            return y + alpha_d * dy, new_x, x_lp + alpha_p * dx_lp, new_s
        alpha_p, alpha_d = BACKTRACK * alpha_p, BACKTRACK * alpha_d
        if alpha_p * alpha_d < STEP_PRODUCT_MIN:
            return None


def _boundary(a: np.ndarray, da: np.ndarray) -> float:
    """The largest α with A + α ΔA ⪰ 0 for A ≻ 0: 1/max(0, −λ_min(L⁻¹ ΔA L⁻ᵀ)), A = LLᵀ
    (+inf when ΔA keeps A definite).  λ_min by Lanczos beyond DENSE_STEP (a Ritz value, to
    LANCZOS_RTOL: the step is then checked by Cholesky factors, _newton_step), else dense."""
    factor, info = la.lapack.dpotrf(a, lower=True)
    if info:
        raise la.LinAlgError("not positive definite")
    w, _ = la.lapack.dsygst(da, factor, itype=1, lower=1)
    w = np.tril(w) + np.tril(w, -1).T
    lowest = None
    if len(w) > DENSE_STEP:
        try:
            lowest = spla.eigsh(w, k=1, which="SA", tol=LANCZOS_RTOL, v0=np.ones(len(w)))[0][0]
        except spla.ArpackNoConvergence:
            pass
    if lowest is None:
        lowest = la.eigvalsh(w, subset_by_index=[0, 0])[0]
    return np.inf if lowest >= 0 else -1.0 / lowest


def _inverse(a: np.ndarray) -> np.ndarray:
    """A⁻¹ for A ≻ 0, from its Cholesky factor (LAPACK potrf, potri)."""
    factor, info = la.lapack.dpotrf(a, lower=True)
    if info:
        raise la.LinAlgError("not positive definite")
    inverse, info = la.lapack.dpotri(factor, lower=True)
    lower = np.tril(inverse)
    return lower + np.tril(inverse, -1).T


def _ratio(v: np.ndarray, dv: np.ndarray) -> float:
    """The largest α with v + α Δv ≥ 0 for v > 0."""
    falling = dv < 0
    return float(np.min(-v[falling] / dv[falling])) if falling.any() else np.inf


def _definite(a: np.ndarray) -> bool:
    try:
        la.cholesky(a, lower=True, check_finite=False)
    except la.LinAlgError:
        return False
    return True


# ----------------------------------------------------------------------------- spectral bundle


def spectral_bundle(c, span: np.ndarray, uniform: float, time_s: float = BUNDLE_TIME_S) -> StiffnessResult:
    """The spectral bundle route (module docstring) for the arguments of optimal_stiffness."""
    t0 = time.perf_counter()
    budget = time_s if remaining() is None else min(time_s, 0.8 * remaining())
    n_bars = c.shape[0]
    scaled = (c / np.sqrt(uniform)).tocsr()  # φ(1) = 1 for the scaled rows

    def evaluate(k, guess=None):
        pairs = smallest_eigenpairs(
            sp.csc_matrix(scaled.T @ sp.diags(k) @ scaled), BUNDLE_CUTS, deflate=span, guess=guess
        )
        return pairs

    k_hat = np.ones(n_bars)
    at_hat = evaluate(k_hat)
    bundle, aggregate = at_hat.vectors, None
    u = 1.0 / n_bars
    upper = np.inf
    iterations = 0
    while time.perf_counter() - t0 < budget:
        check_budget()
        report_progress((time.perf_counter() - t0) / budget, "spectral bundle iterations")
        iterations += 1
        bundle = _soft_part(scaled, bundle, k_hat)
        a_v = scaled @ bundle
        k, model, z, alpha = _master(a_v, aggregate, k_hat, u)
        upper = min(upper, upper_bound(a_v, z, alpha, aggregate))
        at_k = evaluate(k, bundle[:, 0])
        value, best = at_k.values[0], at_hat.values[0]
        predicted = model - best
        if value - best >= SERIOUS * predicted:
            if value - best >= VERY_GOOD * predicted:
                u *= 0.5
            k_hat, at_hat = k, at_k
        else:
            u *= 2.0
        if (upper - lower_of(at_hat)) <= GAP_RTOL * upper:
            break
        bundle, aggregate = _next_bundle(bundle, a_v, z, alpha, aggregate, at_k.vectors, span)
        if iterations % BOUND_EVERY == 0:
            upper = min(upper, _model_bound(scaled, bundle, aggregate, at_hat, span))
    upper = min(upper, _model_bound(scaled, bundle, aggregate, at_hat, span))
    return StiffnessResult.bracketed(lower_of(at_hat), upper, uniform, k_hat, "spectral_bundle", None, iterations,
                                     t0, 1, (c.shape[1] - span.shape[1],))


def upper_bound(a_v: np.ndarray, z: np.ndarray, alpha: float, aggregate: np.ndarray | None) -> float:
    """U(Y) = N_B · max_e c_eᵀ Y c_e for Y = (V Z Vᵀ + α W̄)/(tr Z + α), after projecting Z onto
    the positive semidefinite cone; a_v = C V (N_B × r), ``aggregate`` = (c_eᵀ W̄ c_e)_e."""
    w, u = np.linalg.eigh((z + z.T) / 2)
    w = np.maximum(w, 0.0)
    alpha = max(alpha, 0.0) if aggregate is not None else 0.0
    total = w.sum() + alpha
    if total <= 0:
        return np.inf
    energies = (a_v @ u) ** 2 @ w
    if aggregate is not None:
        energies = energies + alpha * aggregate
    return float(a_v.shape[0] * energies.max() / total)


def lower_of(pairs) -> float:
    """A verified lower bound on λ_min from its Ritz pair: θ − ‖residual‖."""
    return float(pairs.values[0] - pairs.residuals[0])


def _master(a_v: np.ndarray, aggregate, k_hat: np.ndarray, u: float, trust: bool = True):
    """The proximal master problem (module docstring) by Clarabel: (k, model value, Z, α).

    Variables (k, λ); maximise λ − (u/2)‖k − k̂‖² subject to Σk = N_B, k̂/ρ ≤ k ≤ ρk̂ (with
    ``trust``; else k ≥ 0), Σ_e k_e b_e b_eᵀ − λ I ⪰ 0 (b_e the rows of a_v) and λ ≤ ḡᵀk.
    With u = 0 and no trust region its value is max_k φ̂(k) ≥ λ*, and its dual (Z, α) the best
    Y the bundle and the aggregate can offer to the bound U."""
    import clarabel

    m, r = a_v.shape
    rows, cols = np.triu_indices(r)
    # Clarabel's PSD triangle: upper triangle by columns, off-diagonals scaled by √2.
    order = np.lexsort((rows, cols))
    rows, cols = rows[order], cols[order]
    weight = np.where(rows == cols, 1.0, np.sqrt(2.0))
    lmi = (a_v[:, rows] * a_v[:, cols] * weight).T  # (r(r+1)/2, m)
    identity = np.where(rows == cols, 1.0, 0.0)
    lower = k_hat / TRUST_RATIO if trust else np.zeros(m)
    blocks = [
        (sp.csr_matrix(np.append(np.ones(m), 0.0)), np.array([float(m)]), clarabel.ZeroConeT(1)),
        (sp.hstack([-sp.identity(m), sp.csr_matrix((m, 1))]), -lower, clarabel.NonnegativeConeT(m)),
    ]
    if trust:
        blocks.append(
            (sp.hstack([sp.identity(m), sp.csr_matrix((m, 1))]), k_hat * TRUST_RATIO, clarabel.NonnegativeConeT(m))
        )
    aggregate_row = 1 + m * (2 if trust else 1)
    if aggregate is not None:
        blocks.append(
            (sp.csr_matrix(np.append(-aggregate, 1.0)), np.zeros(1), clarabel.NonnegativeConeT(1))
        )
    blocks.append(
        (sp.csr_matrix(-np.column_stack([lmi, -identity])), np.zeros(len(rows)), clarabel.PSDTriangleConeT(r))
    )
    a = sp.vstack([b[0] for b in blocks]).tocsc()
    b = np.concatenate([b[1] for b in blocks])
    p = sp.diags(np.append(np.full(m, u), 0.0)).tocsc()
    q = np.append(-u * k_hat, -1.0)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    solution = clarabel.DefaultSolver(p, q, a, b, [blk[2] for blk in blocks], settings).solve()
    x, y = np.asarray(solution.x), np.asarray(solution.z)
    k = np.clip(x[:m], lower, k_hat * TRUST_RATIO if trust else np.inf)
    k *= m / k.sum()
    dual = y[-len(rows) :] / weight
    z = np.zeros((r, r))
    z[rows, cols] = dual
    z[cols, rows] = dual
    alpha = float(y[aggregate_row]) if aggregate is not None else 0.0
    model = float(np.linalg.eigvalsh((a_v * k[:, None]).T @ a_v)[0])
    if aggregate is not None:
        model = min(model, float(aggregate @ k))
    return k, model, z, alpha


def _model_bound(scaled, bundle, aggregate, at_hat, span) -> float:
    """U from the best Y on the bundle, the aggregate and k̂'s smallest eigenvectors: the dual of
    the master without proximal term or trust region."""
    vectors = np.column_stack([bundle, at_hat.vectors])
    vectors = orthonormal_range(vectors - span @ (span.T @ vectors), BUNDLE_RANK_RTOL)
    a_v = scaled @ vectors
    _, _, z, alpha = _master(a_v, aggregate, np.ones(a_v.shape[0]), 0.0, trust=False)
    return upper_bound(a_v, z, alpha, aggregate)


def _soft_part(scaled, bundle: np.ndarray, k_hat: np.ndarray) -> np.ndarray:
    """The bundle rotated to its Ritz vectors at k̂, those with energy ≤ SOFT_MAX kept."""
    a_v = scaled @ bundle
    energy, rotation = np.linalg.eigh((a_v * k_hat[:, None]).T @ a_v)
    keep = energy <= SOFT_MAX
    keep[0] = True
    return bundle @ rotation[:, keep]


def _next_bundle(bundle, a_v, z, alpha, aggregate, new_vectors, span):
    """The dominant eigenvectors of Z stay; the rest of Z (and the old aggregate, weighted by α)
    becomes the new aggregate; the new point's smallest eigenvectors join (at most BUNDLE_MAX)."""
    w, u = np.linalg.eigh((z + z.T) / 2)
    w = np.maximum(w, 0.0)
    keep = w > KEEP_RTOL * w.max() if w.max() > 0 else np.zeros(w.size, bool)
    dropped = w[~keep].sum() + (alpha if aggregate is not None else 0.0)
    if dropped > 0:
        energies = (a_v @ u[:, ~keep]) ** 2 @ w[~keep]
        if aggregate is not None:
            energies = energies + alpha * aggregate
        aggregate = energies / dropped
    kept = bundle @ u[:, keep][:, ::-1]
    stacked = np.column_stack([kept, new_vectors])[:, :BUNDLE_MAX]
    stacked = stacked - span @ (span.T @ stacked)
    return orthonormal_range(stacked, BUNDLE_RANK_RTOL), aggregate
