"""Springs that make each conformation of a linkage a strict local minimum of the elastic
energy along its motion, with barriers between neighbours (beyond the seed paper; its published
version, Nature Physics 15, 714 (2019), designs rods-and-springs networks whose prescribed
conformations are energy minima).

A spring s joins two nodes not joined by a rod, with stiffness k_s ≥ 0 and rest length L_s:

    E(x) = Σ_s k_s (ℓ_s(x) − L_s)² / 2,      ℓ_s = |x_i − x_j|            (elastic energy)

On the linkage's one-dimensional motion x(s) (s the Euclidean arc length in R^{dN}), with
α_s = k_s and β_s = k_s L_s,

    E(s) = Σ_s α_s ℓ_s(s)²/2 − β_s ℓ_s(s) + const,
    E′(s) = Σ_s (α_s ℓ_s − β_s) ℓ_s′,     E″(s) = Σ_s α_s (ℓ_s′² + ℓ_s ℓ_s″) − β_s ℓ_s″,

all *linear* in (α, β).  So the design's constraints are linear (cvxpy, solved by Clarabel): at each
conformation m, E′ = 0 and E″ ≥ κ (a strict minimum along the motion); between neighbours E
rises monotonically (sample to sample) from each minimum to a chosen peak sample, and the peak
is at least the requested barrier h above both; beyond the first and last conformations E rises
outwards; 0 ≤ k_s ≤ k_max and L_s within REST_RANGE of the spring's lengths along the motion.
The objective is the springs' stored energy at the conformations,
Σ_m E(x_m) = Σ_s Σ_m (α_s ℓ_s,m − β_s)²/(2α_s) (convex: quadratic-over-linear terms, so the
program is a second-order cone program): the least prestress, hence the least force the rods
carry and the least the minima move when the rods give.  Measured on the tristable triangle of
docs/multistable.md (benchmarks/bench_multistable.py, CPU time, load 10–13 on 2 cores): cvxpy +
Clarabel solves it in 0.25–0.31 s, casadi + IPOPT on the same variables, constraints and
objective in 0.75–1.0 s (to the same stored energy within 0.3 %, IPOPT stopping at its
"acceptable" level or on an error in a step); the springs' total force Σ_m Σ_s |α_s ℓ_s,m − β_s|
as objective (a linear program) took 0.32 s and left twice the stored energy.
The barriers are asked of the program with a relative margin BARRIER_MARGIN, which the solver's
tolerance and the exact-minimum correction below can only eat into by far less.

ℓ′ and ℓ″ at a conformation come from the motion's tangent x′ (the unit nontrivial zero mode, ⟂ rigid motions) and its curvature x″ (the
minimum-norm solution of C x″ = −(|Δx′_e|²)_e, the second derivative of every bar's length
along the motion, ⟂ N(C)):

    ℓ′ = Δx·Δx′/ℓ,     ℓ″ = (|Δx′|² + Δx·Δx″ − ℓ′²)/ℓ.

A program that cannot meet h is solved again for the largest barrier it can meet, which
the refusal states.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import cvxpy as cp
import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.errors import DomainError
from zeromode.solver.motion.finite_motion import align_to
from zeromode.solver.multistable.linkage import OUTER_MARGIN, Linkage, flexes
from zeromode.solver.tolerances import SPRING_DROP_RTOL

# Rest lengths allowed, as multiples of (shortest, longest) length of the spring along the
# motion: a spring neither collapses to a point nor is much longer than anything it joins.
REST_RANGE = (0.25, 3.0)
# The curvature floor κ of each minimum along the motion, in units of k_max (a strict minimum,
# with room for the rods' own compliance in the verification).
CURVATURE_FLOOR = 1e-3
# The barrier asked for by default, as a fraction of the largest the springs can make (which a
# linear program finds first): well inside what they can do, and scale-free.
DEFAULT_BARRIER_FRACTION = 0.5
# Relative margin on the barrier asked of the program (Clarabel meets constraints to ~1e-8).
BARRIER_MARGIN = 1e-3


@dataclass(frozen=True, eq=False)
class Springs:
    """pairs (S, 2) node indices (never a rod), stiffness (S,) k_s > 0, rest_length (S,) L_s."""

    pairs: np.ndarray
    stiffness: np.ndarray
    rest_length: np.ndarray

    def energy(self, positions: np.ndarray) -> float:
        """E(x) = Σ k_s (ℓ_s − L_s)²/2 for positions (N, d)."""
        ell = np.linalg.norm(positions[self.pairs[:, 0]] - positions[self.pairs[:, 1]], axis=1)
        return float(0.5 * np.sum(self.stiffness * (ell - self.rest_length) ** 2))


@dataclass(frozen=True)
class Minimum:
    """Conformation ``index`` as a minimum of E along the motion: arc length s, energy,
    curvature E″(s) (exact, from x′ and x″), and the barriers to its neighbours measured on the
    sampled energy (max between the two minima − E here; None without that neighbour)."""

    index: int
    arclength: float
    energy: float
    slope: float
    curvature: float
    barrier_before: float | None
    barrier_after: float | None

    @property
    def barrier(self) -> float | None:
        both = [b for b in (self.barrier_before, self.barrier_after) if b is not None]
        return min(both) if both else None


@dataclass(frozen=True, eq=False)
class Landscape:
    """E along the motion: arclength (P,) s (0 at conformation a, caller's units), energy (P,),
    positions (P, N, d) the sampled configurations (exact conformations among them at
    ``conformation_samples`` (C,)), and each conformation's Minimum."""

    arclength: np.ndarray
    energy: np.ndarray
    positions: np.ndarray
    conformation_samples: np.ndarray
    minima: tuple[Minimum, ...]


@dataclass(frozen=True, eq=False)
class _Samples:
    """Normalised samples of the motion: positions (P, N, d), s (P,), conformation indices
    (C,), candidate pairs (S, 2), lengths (P, S), and at the conformations ℓ′, ℓ″ (C, S)."""

    positions: np.ndarray
    s: np.ndarray
    at: np.ndarray
    pairs: np.ndarray
    ell: np.ndarray
    d1: np.ndarray
    d2: np.ndarray


def design_springs(linkage: Linkage, barrier: float | None, max_stiffness: float = 1.0) -> tuple[Springs, Landscape, float]:
    """Springs on ``linkage`` making every conformation a strict minimum of E along its motion
    with barriers ≥ ``barrier`` between neighbours (energy units: max_stiffness × length²; None:
    DEFAULT_BARRIER_FRACTION of the largest barrier the springs can make): (springs, landscape,
    the barrier asked of them).  DomainError ``no_springs`` (with the largest barrier reachable)
    otherwise."""
    norm = Normalisation.of(linkage.frame.positions)
    r = norm.length
    scale = max_stiffness * r**2  # energy in normalised units × scale = energy
    samples = _samples(linkage, norm)
    best = None
    if barrier is None:
        best = _largest_barrier(samples)
        barrier = DEFAULT_BARRIER_FRACTION * best * scale
    solution = _program(samples, barrier / scale * (1 + BARRIER_MARGIN))
    if solution is None:
        best = _largest_barrier(samples) if best is None else best
        raise DomainError(
            "no_springs",
            f"the largest barrier springs reach between neighbouring conformations is {best * scale:.4g}, "
            f"below the {barrier:.4g} requested.",
        )
    alpha, beta, _ = solution
    keep = alpha > SPRING_DROP_RTOL
    alpha, beta = _exact_minima(samples, alpha, beta, keep)
    springs = Springs(
        samples.pairs[keep], alpha[keep] * max_stiffness, (beta[keep] / alpha[keep]) * r,
    )
    return springs, _landscape(samples, springs, norm), float(barrier)


def _largest_barrier(samples: _Samples) -> float:
    """The largest barrier (normalised units) of the program without one asked; DomainError
    ``no_springs`` when no springs make every conformation a strict minimum at all."""
    best = _program(samples, None)
    if best is None:
        raise DomainError(
            "no_springs",
            "no springs between the linkage's nodes make every conformation a strict minimum of the energy along the motion.",
        )
    return best[2]


def _samples(linkage: Linkage, norm: Normalisation) -> _Samples:
    """The path between the conformations (and OUTER_MARGIN beyond), normalised, with the exact
    conformations inserted at their parameters, aligned to their neighbouring samples."""
    path, taus = linkage.path, linkage.parameters
    margin = OUTER_MARGIN * taus[-1] / (len(taus) - 1)
    keep = (path.parameter >= -margin) & (path.parameter <= taus[-1] + margin)
    tau = list(path.parameter[keep])
    positions = list(path.positions[keep])
    # The exact conformations replace their nearest samples (a polished parameter lies between two).
    at = []
    for j, t in enumerate(taus):
        k = int(np.argmin(np.abs(np.asarray(tau) - t)))
        positions[k] = align_to(linkage.conformations[j], positions[k])
        tau[k] = t
        at.append(k)
    x = norm.positions_in(np.stack(positions))
    n = x.shape[1]
    rods = {tuple(sorted(e)) for e in linkage.frame.edges.tolist()}
    pairs = np.array([p for p in itertools.combinations(range(n), 2) if p not in rods], dtype=np.int64)
    ell = np.linalg.norm(x[:, pairs[:, 0]] - x[:, pairs[:, 1]], axis=-1)
    s = np.asarray(tau) * np.sqrt(n)  # arc length in normalised units
    d1, d2 = [], []
    for j, k in enumerate(at):
        neighbour = x[min(k + 1, len(x) - 1)] - x[max(k - 1, 0)]
        a, b = length_derivatives(x[k], linkage.frame.edges, pairs, neighbour)
        d1.append(a)
        d2.append(b)
    return _Samples(x, s, np.asarray(at), pairs, ell, np.asarray(d1), np.asarray(d2))


def motion_derivatives(x: np.ndarray, edges: np.ndarray, direction: np.ndarray):
    """(x′, x″) of the one-degree-of-freedom motion through x (N, d) by arc length: x′ the unit
    nontrivial zero mode (⟂ rigid motions) signed along ``direction`` (N, d), x″ the
    minimum-norm solution of C x″ = −(|x′_i − x′_j|²)_e (every bar length stationary to second
    order), ⟂ N(C)."""
    c, _, modes = flexes(x, edges)
    t = modes[:, 0]
    t = t if t @ direction.ravel() >= 0 else -t
    tv = t.reshape(x.shape)
    dt = tv[edges[:, 0]] - tv[edges[:, 1]]
    second = np.linalg.lstsq(c, -np.sum(dt * dt, axis=1), rcond=None)[0]
    return tv, second.reshape(x.shape)


def length_derivatives(x: np.ndarray, edges: np.ndarray, pairs: np.ndarray, direction: np.ndarray):
    """(ℓ′, ℓ″) (S,) of the distances of ``pairs`` along the motion through x (module docstring)."""
    t, second = motion_derivatives(x, edges, direction)
    dx = x[pairs[:, 0]] - x[pairs[:, 1]]
    dt = t[pairs[:, 0]] - t[pairs[:, 1]]
    dc = second[pairs[:, 0]] - second[pairs[:, 1]]
    ell = np.linalg.norm(dx, axis=1)
    d1 = np.sum(dx * dt, axis=1) / ell
    d2 = (np.sum(dt * dt, axis=1) + np.sum(dx * dc, axis=1) - d1**2) / ell
    return d1, d2


def _program(samples: _Samples, h: float | None):
    """The program of the module docstring in normalised units (k_max = 1, r = 1):
    (α, β, barrier) minimising the springs' forces with barriers ≥ h, or, with h None, maximising the smallest
    barrier; None when infeasible."""
    ell, s, at = samples.ell, samples.s, samples.at
    n_pairs = ell.shape[1]
    alpha, beta = cp.Variable(n_pairs), cp.Variable(n_pairs)
    energy = (ell**2 / 2) @ alpha - ell @ beta  # (P,), up to a constant
    slope = [(ell[k] * samples.d1[j]) @ alpha - samples.d1[j] @ beta for j, k in enumerate(at)]
    curvature = [(samples.d1[j] ** 2 + ell[k] * samples.d2[j]) @ alpha - samples.d2[j] @ beta for j, k in enumerate(at)]
    lo, hi = REST_RANGE[0] * ell.min(axis=0), REST_RANGE[1] * ell.max(axis=0)
    height = cp.Variable() if h is None else h
    cons = [alpha >= 0, alpha <= 1, beta >= cp.multiply(lo, alpha), beta <= cp.multiply(hi, alpha)]
    cons += [v == 0 for v in slope] + [v >= CURVATURE_FLOOR for v in curvature]
    diff = energy[1:] - energy[:-1]  # diff[k] = E_{k+1} − E_k
    if at[0] > 0:
        cons.append(diff[: at[0]] <= 0)  # E falls towards the first conformation
    if at[-1] < len(s) - 1:
        cons.append(diff[at[-1] :] >= 0)  # and rises beyond the last
    for left, right in itertools.pairwise(at):
        peak = left + 1 + int(np.argmin(np.abs(s[left + 1 : right] - 0.5 * (s[left] + s[right]))))
        cons += [diff[left:peak] >= 0, diff[peak:right] <= 0]
        cons += [energy[peak] - energy[left] >= height, energy[peak] - energy[right] >= height]
    if h is None:
        objective = cp.Maximize(height)
    else:  # Σ_m E(x_m) = Σ_s Σ_m (α_s ℓ_s,m − β_s)²/(2α_s): the springs' stored energy
        objective = cp.Minimize(sum(cp.quad_over_lin(ell[at, i] * alpha[i] - beta[i], alpha[i]) for i in range(n_pairs)) / 2)
    if h is None:
        cons.append(height <= 1.0)
    problem = cp.Problem(objective, cons)
    try:
        with warnings.catch_warnings():  # "inaccurate" solutions are accepted: verify.py judges the result
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if problem.status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or alpha.value is None:
        return None
    got = float(height.value) if h is None else h
    return np.clip(alpha.value, 0.0, 1.0), beta.value, got  # k_max bounds exactly, not to the solver tolerance


def _exact_minima(samples: _Samples, alpha: np.ndarray, beta: np.ndarray, keep: np.ndarray):
    """(α, β) with the dropped springs zeroed and β of the kept ones corrected by the least
    change that makes E′ = 0 exactly at every conformation (the program meets it only to its
    solver's tolerance, and dropping springs moves it)."""
    alpha = np.where(keep, alpha, 0.0)
    beta = np.where(keep, beta, 0.0)
    slope_beta = -samples.d1[:, keep]  # ∂E′_m/∂β_s
    residual = np.array([(samples.ell[k] * samples.d1[j]) @ alpha - samples.d1[j] @ beta for j, k in enumerate(samples.at)])
    beta[keep] -= np.linalg.lstsq(slope_beta, residual, rcond=None)[0]
    return alpha, beta


def _landscape(samples: _Samples, springs: Springs, norm: Normalisation) -> Landscape:
    """The energy at every sample (caller's units) and each conformation's Minimum."""
    r = norm.length
    positions = norm.positions_out(samples.positions)
    energy = np.array([springs.energy(p) for p in positions])
    s = (samples.s - samples.s[samples.at[0]]) * r
    pair_index = {tuple(p): i for i, p in enumerate(samples.pairs.tolist())}
    cols = np.array([pair_index[tuple(p)] for p in springs.pairs.tolist()], dtype=np.int64)
    minima = []
    at = samples.at
    for j, k in enumerate(at):
        ell = samples.ell[k, cols] * r
        d1, d2 = samples.d1[j, cols], samples.d2[j, cols] / r
        slope = float(np.sum(springs.stiffness * (ell - springs.rest_length) * d1))
        curvature = float(np.sum(springs.stiffness * (d1**2 + (ell - springs.rest_length) * d2)))
        before = float(energy[at[j - 1] : k + 1].max() - energy[k]) if j > 0 else None
        after = float(energy[k : at[j + 1] + 1].max() - energy[k]) if j + 1 < len(at) else None
        minima.append(Minimum(j, float(s[k]), float(energy[k]), slope, curvature, before, after))
    return Landscape(s, energy, positions, at.copy(), tuple(minima))
