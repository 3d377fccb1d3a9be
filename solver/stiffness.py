"""The optimal-stiffness margin of a large frame, by a spectral bundle method, with a verified bracket.

    λ* = max { φ(k) : k ∈ Δ },   φ(k) = λ_min(Pᵀ K(k) P),   K(k) = Cᵀ diag(k) C,
    Δ = { k ≥ 0, Σ_e k_e = N_B },   P an orthonormal basis of span^⊥ (span = rigid ⊕ designed),

the problem of certificates.rigidity_margin when the LMI (p = dim span^⊥) is too large for an
interior-point SDP solver.  φ is concave; at k its supergradients are g_e(Y) = c_eᵀ Y c_e for Y
in the convex hull of v vᵀ, v unit eigenvectors of λ_min.  Weak duality gives, for every
Y ⪰ 0 with tr Y = 1 on span^⊥,

    λ* ≤ U(Y) = N_B · max_e c_eᵀ Y c_e,

and φ(k) itself is attained: the certificate is the bracket φ(k̂) ≤ λ* ≤ U(Y), both computed
outside any solver — φ(k̂) as the smallest Ritz value of PᵀK(k̂)P minus its residual norm
(eigen.py: shift-invert Lanczos), U(Y) exactly from Y = V Z Vᵀ + α W̄.

Spectral bundle (Helmberg & Rendl 2000, proximal form, maximising): the model
    φ̂(k) = min( λ_min(Vᵀ K(k) V), ḡᵀ k ) ≥ φ(k)
uses a bundle V (orthonormal, ⟂ span) of eigenvectors met so far and an aggregate ḡ = g(W̄) of
the dropped ones.  Each iteration solves the master problem (Clarabel, one variable per bar)
    max_{k ∈ Δ ∩ [k̂/ρ, ρ k̂]}  φ̂(k) − (u/2)‖k − k̂‖²
whose dual (Z ⪰ 0 on the bundle, α ≥ 0 on the aggregate) is a feasible Y for U; evaluates φ at
the new k (a serious step moves k̂ there when it realises a fraction of the predicted increase;
a null step enlarges the bundle), and keeps the bundle small: the dominant part of Z, plus the
new point's smallest eigenvectors.  The multiplicative trust region [k̂/ρ, ρ k̂] keeps every bar
alive, so a step cannot make the frame floppy.  The problem is scaled so that φ(1) = 1.

It stops when (U − φ(k̂))/U ≤ GAP_RTOL, or after TIME_S seconds (or the request's budget): the
bracket is verified either way, and the status says whether the target gap was met.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from zeromode.solver.budget import check_budget, remaining
from zeromode.solver.eigen import smallest_eigenpairs
from zeromode.solver.progress import report_progress
from zeromode.solver.rank import orthonormal_range

# Relative gap (U − L)/U at which the bracket is closed.
GAP_RTOL = 1e-3
# Wall time of one optimisation, within the request's budget (budget.py) when there is one.
TIME_S = 40.0
# Smallest eigenpairs evaluated per point (the new cuts) and the bundle's largest size.
EIGENPAIRS = 4
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
class BundleResult:
    """lower ≤ λ* ≤ upper (verified); stiffness: k̂ (N_B, Σ = N_B) attaining ``lower``;
    status "optimal" (gap ≤ GAP_RTOL) or "gap_not_closed"; iterations; time_ms."""

    lower: float
    upper: float
    stiffness: np.ndarray
    status: str
    iterations: int
    time_ms: float


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


def optimal_stiffness(c, span: np.ndarray, uniform: float, time_s: float = TIME_S) -> BundleResult:
    """max_k λ_min(Pᵀ Cᵀ diag(k) C P) over Δ for the normalised C (N_B × dN, sparse) and
    span (dN × q orthonormal, P its complement); ``uniform`` = φ(1) > 0; at most ``time_s``
    seconds (and 80 % of what is left of the request's budget)."""
    t0 = time.perf_counter()
    budget = time_s if remaining() is None else min(time_s, 0.8 * remaining())
    n_bars = c.shape[0]
    scaled = (c / np.sqrt(uniform)).tocsr()  # φ(1) = 1 for the scaled rows

    def evaluate(k, guess=None):
        pairs = smallest_eigenpairs(
            sp.csc_matrix(scaled.T @ sp.diags(k) @ scaled), EIGENPAIRS, deflate=span, guess=guess
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
    lower = lower_of(at_hat)
    return BundleResult(
        lower=lower * uniform,
        upper=upper * uniform,
        stiffness=k_hat,
        status="optimal" if upper - lower <= GAP_RTOL * upper else "gap_not_closed",
        iterations=iterations,
        time_ms=1e3 * (time.perf_counter() - t0),
    )


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
    vectors = orthonormal_range(vectors - span @ (span.T @ vectors), 1e-8)
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
    return orthonormal_range(stacked, 1e-8), aggregate
