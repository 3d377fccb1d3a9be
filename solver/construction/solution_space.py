"""The solution space of one unspecified node joined to k specified nodes (paper, Eqs. 4–6).

For specified positions x_S and motions u_S (k × d each), an unspecified node at x_U moving
with u_U keeps every bar (x_Si − x_U)·(u_Si − u_U) = 0 iff

    A v = b + c·1,   A = [u_Siᵀ  x_Siᵀ] (k × 2d),  v = (x_U, u_U),  b_i = x_Si·u_Si,  c = x_U·u_U.

Treating the product c = x_U·u_U as a free unknown linearises this to Ã ṽ = b with Ã = [A, −1] (k × (2d+1)),
ṽ = (x_U, u_U, c).  If b ∈ R(Ã) the solutions are ṽ = W̃ α̃, W̃ = [w_1 … w_m, ṽ*] with
W = [w_1 … w_m] a basis of N(Ã), ṽ* = Ã⁺b and α̃ = (α, 1); c = x_U·u_U then becomes the quadric
α̃ᵀ Q α̃ = 0 (Supplementary Methods: Q = W̃ᵀ O W̃ − sym(W̃ᵀ p e_{m+1}ᵀ), O the x·u form,
p the selector of c), so the solution set has dimension m − 1: points (m = 1), a conic (m = 2),
a quadric surface (m = 3), a quadric hypersurface (m ≥ 4).

Decisions (m, whether b ∈ R(Ã), whether a point is a solution) are made on the normalised
problem — positions centred and divided by their RMS radius, motions centred and divided by
theirs; the bar constraints are invariant under both maps — so they do not depend on units.
W̃ and Q are reported in the caller's coordinates, built with the rank decided there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.analysis.rank import RTOL, decide_rank
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import check_positions
from zeromode.solver.tolerances import CONSTRAINT_ATOL

KINDS = {0: "points", 1: "points", 2: "conic", 3: "quadric_surface"}


def linear_system(positions: np.ndarray, motions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ã = [u_Siᵀ, x_Siᵀ, −1] (k × (2d+1)) and b_i = x_Si·u_Si (paper, Eqs. 4–5)."""
    k = len(positions)
    a_tilde = np.hstack([motions, positions, -np.ones((k, 1))])
    return a_tilde, np.einsum("ij,ij->i", positions, motions)


def quadric_matrix(w_tilde: np.ndarray, d: int) -> np.ndarray:
    """Q (Supplementary Methods) for W̃ = [W, ṽ*] with rows (x_U, u_U, c).

    α̃ᵀQα̃ = ṽᵀOṽ − pᵀṽ·α̃_{m+1} with ṽ = W̃α̃: O extracts x_U·u_U, p selects c.
    """
    o = np.zeros((2 * d + 1, 2 * d + 1))
    o[:d, d : 2 * d] = 0.5 * np.eye(d)
    o[d : 2 * d, :d] = 0.5 * np.eye(d)
    q = w_tilde.T @ o @ w_tilde
    linear = w_tilde[2 * d]  # pᵀW̃: the c-row
    q[:, -1] -= 0.5 * linear
    q[-1, :] -= 0.5 * linear
    return 0.5 * (q + q.T)  # exactly symmetric (the products above differ in the last bit)


@dataclass(frozen=True, eq=False)
class SolutionSpace:
    """All (x_U, u_U) compatible with k specified nodes.

    w_tilde: (2d+1) × (m+1) [W, ṽ*] and quadric: (m+1) × (m+1) Q, in the caller's coordinates.
    The normalised twins (``w_tilde_n``, ``quadric_n``, ``norm``) drive sampling and checks.
    """

    dim: int
    positions: np.ndarray
    motions: np.ndarray
    nullity: int
    w_tilde: np.ndarray
    quadric: np.ndarray
    w_tilde_n: np.ndarray
    quadric_n: np.ndarray
    norm: Normalisation

    @property
    def dimension(self) -> int:
        """m − 1; a consistent m = 0 system is the single point ṽ* (dimension 0)."""
        return max(self.nullity - 1, 0)

    @property
    def kind(self) -> str:
        return KINDS.get(self.nullity, "quadric_hypersurface")

    def points(self, alphas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x_U, u_U) in the caller's coordinates for normalised coordinates α, shape (n, m) → (n, d) twice."""
        v = np.hstack([alphas, np.ones((len(alphas), 1))]) @ self.w_tilde_n.T
        d = self.dim
        return self.norm.positions_out(v[:, :d]), self.norm.motions_out(v[:, d : 2 * d])

    def sample(self, n: int, rng: np.random.Generator, spread: float = 1.5) -> tuple[np.ndarray, np.ndarray]:
        """Up to n real solutions: positions (n', d) and motions (n', d), each verified against all
        k bar constraints.

        Random lines α0 + t·δ in α-space (α0 ~ N(0, spread²), δ uniform on the sphere) are cut
        with the quadric: (α0 + tδ, 1)ᵀ Q (α0 + tδ, 1) = 0 is a quadratic in t.  For m = 1 the
        single α-line is cut (at most two points); for m = 0 the particular solution is tested.
        """
        m = self.nullity
        if m == 0:
            alphas = np.zeros((1, 0))
        else:
            lines = 1 if m == 1 else max(2 * n, 8)
            a0 = spread * rng.standard_normal((lines, m)) if m > 1 else np.zeros((1, 1))
            delta = rng.standard_normal((lines, m))
            delta /= np.linalg.norm(delta, axis=1, keepdims=True)
            t, ok = real_roots_on_lines(self.quadric_n, a0, delta)
            alphas = (a0[:, None, :] + t[:, :, None] * delta[:, None, :])[ok]
        x_u, u_u = self.points(alphas)
        good = np.max(np.abs(self.residuals(x_u, u_u)), axis=1, initial=0.0) <= CONSTRAINT_ATOL
        return x_u[good][:n], u_u[good][:n]

    def residuals(self, x_u: np.ndarray, u_u: np.ndarray) -> np.ndarray:
        """Normalised bar constraints (x'_Si − x'_U)·(u'_Si − u'_U): shape (n, k) for n points."""
        xs, us = self.norm.positions_in(self.positions), self.norm.motions_in(self.motions)
        xu, uu = self.norm.positions_in(x_u), self.norm.motions_in(u_u)
        return np.einsum("nkd,nkd->nk", xs[None] - xu[:, None], us[None] - uu[:, None])


@dataclass(frozen=True, eq=False)
class SolutionSamples:
    """Verified real points of a solution space: positions x_U (n, d), motions u_U (n, d), and
    the largest |normalised bar constraint| among them (0 for no point)."""

    positions: np.ndarray
    motions: np.ndarray
    max_residual: float


def seeded_samples(space: SolutionSpace, n: int, seed: int) -> SolutionSamples:
    """Up to n verified solutions of ``space`` drawn with a seeded generator (same seed, same points)."""
    x_u, u_u = space.sample(n, np.random.default_rng(seed))
    residual = float(np.abs(space.residuals(x_u, u_u)).max(initial=0.0)) if len(x_u) else 0.0
    return SolutionSamples(x_u, u_u, residual)


def real_roots_on_lines(q: np.ndarray, a0: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real t with (a0 + tδ, 1)ᵀ Q (a0 + tδ, 1) = 0 for each line: t (L, 2) and a validity mask."""
    p0 = np.hstack([a0, np.ones((len(a0), 1))])
    p1 = np.hstack([delta, np.zeros((len(delta), 1))])
    a = np.einsum("li,ij,lj->l", p1, q, p1)
    b = 2 * np.einsum("li,ij,lj->l", p1, q, p0)
    c = np.einsum("li,ij,lj->l", p0, q, p0)
    disc = b * b - 4 * a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    # Stable pair of roots: t1 = qq/a, t2 = c/qq with qq = −(b + sign(b)·√disc)/2.
    qq = -0.5 * (b + np.copysign(root, b))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.column_stack([qq / a, c / qq])
    ok = (disc >= 0)[:, None] & np.isfinite(t)
    return np.where(ok, t, 0.0), ok


def check_targets(positions, motions, dim: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Validate x_S and u_S (k × d each, finite, same shape); raise InvalidInput otherwise."""
    x = check_positions(positions, dim, "positions")
    u = check_positions(motions, x.shape[1], "motions")
    if u.shape != x.shape:
        raise InvalidInput(
            "invalid_shape", f"motions must have one row per specified node ({len(x)}), got {len(u)}."
        )
    return x, u


def solution_space(positions, motions, dim: int | None = None, rtol: float = RTOL) -> SolutionSpace:
    """Build the solution space of one unspecified node joined to all k specified nodes.

    Raises DomainError ``no_solution`` when b ∉ R(Ã) (decided on the normalised system).
    """
    x, u = check_targets(positions, motions, dim)
    d = x.shape[1]
    norm = Normalisation.of(x, u)
    a_n, b_n = linear_system(norm.positions_in(x), norm.motions_in(u))
    uu, s, vt = np.linalg.svd(a_n, full_matrices=True)
    rank, _ = decide_rank(s, rtol)
    residual = np.linalg.norm(uu[:, rank:].T @ b_n)
    if residual > CONSTRAINT_ATOL * max(np.linalg.norm(b_n), 1.0):
        raise DomainError(
            "no_solution",
            "no unspecified node can join all specified nodes: b is not in the range of Ã "
            f"(relative residual {residual / max(np.linalg.norm(b_n), 1.0):.1e}).",
        )
    w_n = vt[rank:].T
    v_n = vt[:rank].T @ ((uu[:, :rank].T @ b_n) / s[:rank])
    w_tilde_n = np.column_stack([w_n, v_n])
    w_tilde = _original_basis(x, u, rank)
    if not np.all(np.isfinite(w_tilde)) or not np.all(np.isfinite(quadric_matrix(w_tilde, d))):
        raise InvalidInput(
            "out_of_range",
            "positions × motions overflow double precision in the caller's units; rescale the input.",
        )
    space = SolutionSpace(
        dim=d,
        positions=x,
        motions=u,
        nullity=w_n.shape[1],
        w_tilde=w_tilde,
        quadric=quadric_matrix(w_tilde, d),
        w_tilde_n=w_tilde_n,
        quadric_n=quadric_matrix(w_tilde_n, d),
        norm=norm,
    )
    if space.nullity == 0 and not len(space.sample(1, np.random.default_rng(0))[0]):
        raise DomainError(
            "no_solution",
            "no unspecified node can join all specified nodes: Ã ṽ = b has the single solution "
            "ṽ* = Ã⁺b, and it violates c = x_U·u_U.",
        )
    return space


def _original_basis(x: np.ndarray, u: np.ndarray, rank: int) -> np.ndarray:
    """W̃ = [orthonormal basis of N(Ã), Ã⁺b] in the caller's coordinates, with the decided rank."""
    a, b = linear_system(x, u)
    uu, s, vt = np.linalg.svd(a, full_matrices=True)
    particular = vt[:rank].T @ ((uu[:, :rank].T @ b) / s[:rank])
    return np.column_stack([vt[rank:].T, particular])
