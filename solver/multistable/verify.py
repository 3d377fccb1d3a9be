"""Independent verification of a multistable design in the full configuration space: the rods
become stiff springs of stiffness K = ROD_STIFFNESS_RATIO · k_max, so the elastic energy is

    U(x) = Σ_rods K (ℓ_e − l_e)²/2 + Σ_springs k_s (ℓ_s − L_s)²/2,

with gradient ∂U/∂x_i = Σ k (ℓ − L) e (e the unit vector from j to i) and the Hessian blocks

    H_ii = H_jj = −H_ij = k [e eᵀ + (1 − L/ℓ)(I − e eᵀ)]   per spring or rod (i, j).

Each conformation, relaxed by Newton's trust region (scipy.optimize, method "trust-krylov"), must
stay where it is (the rods give by about the springs' force over K) with a Hessian positive
definite on the complement of the rigid motions; relaxations from seeded perturbations (a random
displacement of PERTURBATION × its distance along the motion to the nearest barrier peak) must
come back to it.  Nothing of the motion's derivatives or the linear program is reused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.analysis.rank import complement_within
from zeromode.solver.analysis.rigidity import rigid_motions
from zeromode.solver.budget import check_budget
from zeromode.solver.motion.finite_motion import kabsch_distance
from zeromode.solver.multistable.springs import Landscape, Springs
from zeromode.solver.tolerances import MINIMUM_LANDING_RTOL, RELAXATION_GRADIENT_RTOL

ROD_STIFFNESS_RATIO = 1e5
RELAXATIONS = 3
PERTURBATION = 0.02
# Trust-region iterations (its gradient tolerance is tolerances.RELAXATION_GRADIENT_RTOL).
MAX_ITERATIONS = 500
# The trust region hands over to Newton once the gradient is within this factor of gtol (Newton
# converges from there; from further, on the stiff rods, it may not).
HANDOVER_GRADIENT = 1e5
# Newton steps polishing each relaxation (quadratic convergence: 3 take 1e-5 to round-off).
NEWTON_STEPS = 6
# The rods' give may move a minimum of the stiff-rod energy off its conformation by at most this
# fraction of the distance to the nearest other conformation (it is then still that minimum).
SAME_MINIMUM_RATIO = 0.1


@dataclass(frozen=True)
class MinimumCheck:
    """For conformation ``index``: how far its relaxation moved it (Kabsch distance over the
    RMS radius · √N; shift_ratio: over the distance to the nearest other conformation), the smallest eigenvalue of the Hessian of U there on the complement of
    the rigid motions (PD iff > 0), and the worst landing of the seeded relaxations (their
    distance to this relaxed minimum over the RMS radius · √N, and the ratio of that to the
    distance to the nearest other conformation: < 1 means it came back to this one)."""

    index: int
    relaxed_shift: float
    shift_ratio: float
    hessian_min_eigenvalue: float
    worst_landing: float
    worst_landing_ratio: float

    @property
    def ok(self) -> bool:
        return (
            self.hessian_min_eigenvalue > 0
            and self.shift_ratio <= SAME_MINIMUM_RATIO
            and self.worst_landing <= MINIMUM_LANDING_RTOL
            and self.worst_landing_ratio < 1
        )


class StiffRodEnergy:
    """U(x) of the module docstring for rods (edges, lengths) and springs; x flat (dN)."""

    def __init__(self, edges, lengths, springs: Springs, dim: int, rod_stiffness: float):
        self.pairs = np.concatenate([np.asarray(edges, dtype=np.int64).reshape(-1, 2), springs.pairs])
        self.k = np.concatenate([np.full(len(lengths), rod_stiffness), springs.stiffness])
        self.rest = np.concatenate([lengths, springs.rest_length])
        self.dim = dim

    def _geometry(self, x):
        y = x.reshape(-1, self.dim)
        delta = y[self.pairs[:, 0]] - y[self.pairs[:, 1]]
        ell = np.linalg.norm(delta, axis=1)
        return y, delta, ell

    def value(self, x) -> float:
        _, _, ell = self._geometry(x)
        return float(0.5 * np.sum(self.k * (ell - self.rest) ** 2))

    def gradient(self, x) -> np.ndarray:
        y, delta, ell = self._geometry(x)
        force = (self.k * (ell - self.rest) / ell)[:, None] * delta
        g = np.zeros_like(y)
        np.add.at(g, self.pairs[:, 0], force)
        np.add.at(g, self.pairs[:, 1], -force)
        return g.ravel()

    def hessian(self, x) -> np.ndarray:
        y, delta, ell = self._geometry(x)
        n, d = y.shape
        h = np.zeros((n, d, n, d))
        e = delta / ell[:, None]
        outer = e[:, :, None] * e[:, None, :]
        blocks = self.k[:, None, None] * (outer + (1 - self.rest / ell)[:, None, None] * (np.eye(d) - outer))
        for (i, j), b in zip(self.pairs, blocks):
            h[i, :, i, :] += b
            h[j, :, j, :] += b
            h[i, :, j, :] -= b
            h[j, :, i, :] -= b
        return h.reshape(n * d, n * d)


def check_minima(frame, conformations: np.ndarray, springs: Springs, landscape: Landscape, max_stiffness: float, seed: int = 0):
    """MinimumCheck per conformation (C, N, d) of the rods (``frame``) and springs."""
    rest = np.linalg.norm(frame.positions[frame.edges[:, 0]] - frame.positions[frame.edges[:, 1]], axis=1)
    energy = StiffRodEnergy(frame.edges, rest, springs, frame.dim, ROD_STIFFNESS_RATIO * max_stiffness)
    r = Normalisation.of(frame.positions).length
    unit = r * np.sqrt(frame.n_nodes)
    relax = lambda x0: _relaxed(energy, x0, RELAXATION_GRADIENT_RTOL * max_stiffness * r)
    relaxed = [relax(c) for c in conformations]
    rng = np.random.default_rng(seed)
    s, peaks = landscape.arclength, _peaks(landscape)
    checks = []
    for j, (c, x) in enumerate(zip(conformations, relaxed)):
        q = complement_within(np.eye(x.size), rigid_motions(Normalisation.of(x).positions_in(x)))
        eigen = float(np.linalg.eigvalsh(q.T @ energy.hessian(x.ravel()) @ q)[0])
        reach = min(abs(s[p] - s[landscape.conformation_samples[j]]) for p in peaks[j])
        others = [y for i, y in enumerate(relaxed) if i != j]
        landing, ratio = 0.0, 0.0
        for _ in range(RELAXATIONS):
            check_budget()
            kick = rng.standard_normal(x.shape)
            got = relax(x + PERTURBATION * reach * kick / np.linalg.norm(kick))
            dist = kabsch_distance(got, x)
            landing = max(landing, dist / unit)
            ratio = max(ratio, dist / min(kabsch_distance(got, y) for y in others))
        shift = kabsch_distance(x, c)
        nearest = min(kabsch_distance(c, y) for i, y in enumerate(conformations) if i != j)
        checks.append(MinimumCheck(j, shift / unit, shift / nearest, eigen, landing, ratio))
    return tuple(checks)


def _relaxed(energy: StiffRodEnergy, x0: np.ndarray, gtol: float) -> np.ndarray:
    """A local minimum of U from x0 (N, d): scipy's "trust-krylov" (Lanczos on the Hessian),
    "trust-exact" from where it stopped if it stalled far from a stationary point, then Newton steps x ← x − H⁺∇U (H⁺ the pseudo-inverse: the rigid motions are U's exact null
    directions) while they shrink the gradient.  The trust region stops at "no predicted
    improvement" once the energy's round-off (the rods' K·strain² terms) hides the soft mode's
    decrease, which can leave ∇U/E″ ~ 1e-5 of the RMS radius along the motion; Newton needs no
    energy differences and takes it to round-off."""
    x = x0.ravel()
    with np.errstate(all="ignore"):
        for method in ("trust-krylov", "trust-exact"):
            res = minimize(energy.value, x, jac=energy.gradient, hess=energy.hessian, method=method,
                           options={"maxiter": MAX_ITERATIONS, "gtol": gtol})
            if np.all(np.isfinite(res.x)):
                x = res.x
            if np.linalg.norm(energy.gradient(x)) <= HANDOVER_GRADIENT * gtol:
                break
        g = energy.gradient(x)
        for _ in range(NEWTON_STEPS):
            step = np.linalg.lstsq(energy.hessian(x), g, rcond=None)[0]
            trial = x - step
            g_trial = energy.gradient(trial)
            if not np.linalg.norm(g_trial) < np.linalg.norm(g):
                break
            x, g = trial, g_trial
    return x.reshape(-1, energy.dim)


def _peaks(landscape: Landscape) -> list[list[int]]:
    """For each conformation, the sample indices of the highest energy between it and each
    neighbour (or the path's end samples, for an outer side)."""
    at, e = landscape.conformation_samples, landscape.energy
    out = []
    for j, k in enumerate(at):
        sides = []
        lo = at[j - 1] if j > 0 else 0
        hi = at[j + 1] if j + 1 < len(at) else len(e) - 1
        if lo < k:
            sides.append(lo + int(np.argmax(e[lo:k])))
        if hi > k:
            sides.append(k + 1 + int(np.argmax(e[k + 1 : hi + 1])))
        out.append(sides)
    return out
