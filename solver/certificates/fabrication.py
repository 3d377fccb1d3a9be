"""Fabrication tolerance: how precisely must a design be built to do what it was designed for?

Everything is computed on the normalised frame (positions centred and divided by their RMS
radius, normalisation.py), so tolerances are relative and scale-free.

Errors.  A built frame differs from the design in
  * pin positions: x' = x + δx, each coordinate of each node independently uniform in
    ±ε·ℓ̄ (ℓ̄ the mean bar length);
  * bar lengths: ℓ'_b = ℓ_b(1 + η_b), η_b independently uniform in ±ε; the frame is assembled
    at x' solving ½(|x'_i − x'_j|² − ℓ'_b²) = 0 with x' − x ⟂ N(C(x)) (Gauss–Newton; least
    squares where self-stresses make the lengths incompatible). To first order, since
    ½ d|x_i − x_j|² = (C δx)_b, C δx = ℓ² ∘ η and δx = C⁺(ℓ² ∘ η): no part along the zero modes
    (where a mechanism sits along its motion is the user's choice, not an error).
So in both cases δx = ε·B ξ with ξ uniform in [−1, 1]^n: B = ℓ̄·I (pins) or C⁺ diag(ℓ²) (lengths).

The linearisation of C(x)u = 0.  C is bilinear: (C(x)u)_b = (x_i − x_j)·(u_i − u_j) = (C(u)x)_b.
A zero mode u of the design, continued in the perturbed frame as u + δu, satisfies to first order
    C(x) δu + C(δx) u = 0,   i.e.   C(x) δu = −C(u) δx,
a linear solve: δu = −C⁺ C(u) δx (minimum norm; any further part in N(C) only re-mixes the zero
modes among themselves, which the quantities below do not see).  When the frame has
self-stresses Σ (orthonormal, Cᵀ Σ = 0), the part Σᵀ C(u) δx of the right-hand side is outside
the range of C and cannot be absorbed: the mode is no longer exact and costs energy
    ‖C(x') û‖² ≈ ‖Σᵀ C(û) δx‖²   (û of unit norm),
which is second order in the error: the mechanism stiffens.  The designed subspace at x' is
therefore taken as the soft subspace: the z right singular vectors of C(x') with the smallest
singular values (z = d(d+1)/2 + M, rigid motions plus designed modes); without self-stress it
is N(C(x')) exactly.

Quantities (each relative; J its Jacobian with respect to the normalised δx):
  mode             the designed motion at the nodes D it was designed for (an allosteric
                   design's sites, else the specified nodes, else all nodes):
                   r = (I − P_D) u_D/‖u_D‖, P_D the projector onto the rows D of the soft
                   subspace: how far the built frame is from still moving D as asked (0 at the
                   design); J = (I − P_D)[J_u]_D/‖u_D‖, J_u = −C⁺C(u) (several modes stacked,
                   divided by √Σ‖u_D‖²);
  poisson_ratio    a lattice's ν = −ε_y/ε_x = −(A_y u · A_x x)/(A_x u · A_y x), A_x, A_y the
                   boundary functionals (mean over right minus left of the x components, top
                   minus bottom of the y components; boundary_strain.boundary_strains), u the soft
                   subspace's part ⟂ the rigid motions R(x') = span G(x'); to first order
                   δ(P⊥u) = δu − G(GᵀG)⁻¹ H δx with H's rows 0 (translations) and −g_ab(u)ᵀ
                   (rotations g_ab(x)_i = E_ab x_i), and δν/ν = A_yδu/A_yu − A_xδu/A_xu
                   + A_xδx/A_xx − A_yδx/A_yx;
  target_response  an allosteric design's response: the zero mode w = N N_S⁺ u_S driven by the
                   source rows u_S; ‖δw_T‖/‖w_T‖ with δw_T = δu_T − N_T N_S⁺ δu_S (the gauge
                   part of δu cancels: N_S has full column rank);
  rigidity_margin  λ = σ²_{z+1}, the smallest eigenvalue of CᵀC past the z soft ones (unit bar
                   stiffness; at the design the uniform margin of certificates.rigidity_margin);
                   δλ/λ = 2 yᵀC(v)δx/σ (y, v its singular vectors; first order while σ is
                   simple);
  mode_stiffness   frames with self-stresses only: Σ_m ‖C(x')û_m‖²/λ, the designed modes'
                   energy relative to the margin (0 at the design, second order:
                   ≈ ‖Σᵀ C(Û) δx‖²/λ, Û an orthonormal basis of the designed modes ⟂ R).

Tolerances.  For a linear quantity, the RMS change over the error distribution is
ε·‖J B‖_F/√3 (uniform ±1 has variance 1/3), so ε* = budget·√3/‖J B‖_F keeps it at the budget;
for mode_stiffness the mean is ε²‖J B‖²_F/(3λ) and ε* = √(3λ·budget)/‖J B‖_F.  A seeded Monte
Carlo of ``samples`` perturbed frames at ε* (at MAX_ERROR when ε* is larger) evaluates each
quantity exactly; the estimate agrees when the Monte Carlo statistic is within a factor
AGREEMENT_FACTOR of the linear prediction at that ε.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.analysis.rigidity import compatibility_matrix, rigid_motions
from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.boundary_strain import poisson_ratio
from zeromode.solver.progress import progress_stage, report_progress
from zeromode.solver.tolerances import (
    ASSEMBLY_TOL,
    GIVEN_MODE_RTOL,
    INSENSITIVE,
    RANK_RTOL,
    RIGID_RTOL,
)

# The linear estimate agrees with the Monte Carlo when their statistics are within this factor:
# the Monte Carlo's own sampling error at 64 samples is ~10 %, so a factor 2 separates a wrong
# linearisation (a nearly degenerate margin, an error past the linear range) from noise.
AGREEMENT_FACTOR = 2.0
# Errors beyond ±10 % are not fabrication tolerances; the Monte Carlo stops there.
MAX_ERROR = 0.1
# One dense eigen-decomposition of CᵀC per Monte Carlo frame (about 30 ms at dN = 400 on one
# core; 8 quantity–error pairs × 64 frames): frames up to this many degrees of freedom.
MAX_DOF = 400
# Gauss–Newton steps of the assembly of a frame with perturbed lengths (to ASSEMBLY_TOL).
ASSEMBLY_STEPS = 50
ERRORS = ("bar_lengths", "pin_positions")


@dataclass(frozen=True)
class ToleranceEstimate:
    """One quantity under one kind of error.

    sensitivity: the statistic (RMS relative change; mean for mode_stiffness) per unit error ε
    (per ε² for mode_stiffness) by the linearisation; tolerance: ε* (fraction: of each length,
    or of the mean bar length for pin positions), None when the quantity does not change to
    first order; tested_error: the ε of the Monte Carlo (ε*, or MAX_ERROR when ε* is larger);
    predicted: the linear statistic at tested_error; monte_carlo, monte_carlo_p95: the
    statistic and the 95th percentile of the change over the samples; agrees: predicted and
    monte_carlo within AGREEMENT_FACTOR; failed: samples whose frame could not be assembled.
    """

    quantity: str
    error: str
    sensitivity: float
    tolerance: float | None
    tested_error: float | None
    predicted: float | None
    monte_carlo: float | None
    monte_carlo_p95: float | None
    agrees: bool | None
    failed: int = 0


@dataclass(frozen=True)
class ToleranceReport:
    """budget: the relative change tolerated (0.01: 1 %); samples, seed: the Monte Carlo's;
    mean_bar_length: ℓ̄ in the caller's units (pin tolerances are fractions of it);
    self_stresses: of the design; estimates: one per quantity and kind of error."""

    budget: float
    samples: int
    seed: int
    agreement_factor: float
    mean_bar_length: float
    self_stresses: int
    estimates: tuple[ToleranceEstimate, ...]


def check_tolerance_request(frame: Frame, budget: float, samples: int) -> None:
    """tolerance_report's refusals before any work: InvalidInput ``invalid_options`` for the
    budget or sample count, DomainError ``too_expensive`` past MAX_DOF degrees of freedom."""
    if not 0 < budget < 1:
        raise InvalidInput("invalid_options", f"the tolerance budget must be in (0, 1), got {budget}.")
    if samples < 2:
        raise InvalidInput("invalid_options", f"the Monte Carlo needs at least 2 samples, got {samples}.")
    n_dof = frame.dim * frame.n_nodes
    if n_dof > MAX_DOF:
        raise DomainError(
            "too_expensive",
            f"tolerances are computed for frames of up to {MAX_DOF} degrees of freedom; this one has {n_dof}.",
        )


def tolerance_report(
    frame: Frame,
    modes,
    *,
    boundary: Mapping[str, Sequence[int]] | None = None,
    source: Sequence[int] = (),
    target: Sequence[int] = (),
    budget: float = 0.01,
    samples: int = 64,
    seed: int = 0,
) -> ToleranceReport:
    """Tolerances of a design — frame and its M designed zero modes (M, N, d) — to errors in bar
    lengths and pin positions; see the module docstring. boundary: a lattice's boundary node
    sets (adds poisson_ratio); source, target: an allosteric design's sites (adds
    target_response, driven by the first mode's source rows). Raises InvalidInput for a bad
    budget or sample count, DomainError ``too_expensive`` past MAX_DOF, ``no_motion`` when the
    modes are not zero modes of the frame or the frame has other zero modes."""
    check_tolerance_request(frame, budget, samples)
    n, d = frame.n_nodes, frame.dim
    norm = Normalisation.of(frame.positions)
    design = _Design.at(norm.positions_in(frame.positions).ravel(), frame.edges, n, d, modes, norm.length)
    driven = list(source) + list(target) or list(frame.specified) or list(range(n))
    quantities = [_mode_quantity(design, driven)]
    if boundary:
        quantities.append(_poisson_quantity(design, boundary))
    if len(source) and len(target):
        quantities.append(_target_quantity(design, source, target))
    quantities.append(_margin_quantity(design))
    if design.stresses.shape[1]:
        quantities.append(_stiffness_quantity(design))
    # δx = ε·B ξ, ξ uniform in [−1, 1]: pins move by ε·ℓ̄, lengths change by ε·ℓ.
    maps = {"pin_positions": design.mean_length * np.eye(n * d), "bar_lengths": design.pinv * design.lengths**2}
    rng = np.random.default_rng(seed)
    pairs = [(error, q) for error in ERRORS for q in quantities]
    estimates = []
    for i, (error, q) in enumerate(pairs):
        with progress_stage(i / len(pairs), (i + 1) / len(pairs), f"{q.name} under {error}"):
            estimates.append(_estimate(design, q, error, maps[error], budget, samples, rng))
    return ToleranceReport(
        budget, samples, seed, AGREEMENT_FACTOR, design.mean_length * norm.length,
        int(design.stresses.shape[1]), tuple(estimates),
    )


@dataclass(frozen=True, eq=False)
class _Design:
    """The design in normalised units: x (dN,), edges, n, d, modes (M, dN), C and its full SVD
    (u_svd, s_pad zero-padded to dN, vt), C⁺, rigid motions R, self-stresses Σ, bar lengths,
    z = ρ + M and the index of σ_{z+1} in s_pad."""

    x: np.ndarray
    edges: np.ndarray
    n: int
    d: int
    modes: np.ndarray
    c: np.ndarray
    u_svd: np.ndarray
    s_pad: np.ndarray
    vt: np.ndarray
    pinv: np.ndarray
    rigid: np.ndarray
    stresses: np.ndarray
    lengths: np.ndarray
    z: int
    margin_index: int

    @classmethod
    def at(cls, x, edges, n, d, modes, length) -> _Design:
        modes = np.asarray(modes, dtype=float).reshape(-1, n * d) / length  # any scale will do
        c = compatibility_matrix(x.reshape(n, d), edges, dense=True)
        u_svd, s, vt = np.linalg.svd(c, full_matrices=True)
        s_pad = np.concatenate([s, np.zeros(n * d - len(s))])
        rank = int(np.count_nonzero(s > RANK_RTOL * s[0])) if len(s) else 0
        rigid = rigid_motions(x.reshape(n, d))
        z = rigid.shape[1] + len(modes)
        residual = np.linalg.norm(c @ modes.T, axis=0) / (np.linalg.norm(modes, axis=1) * np.linalg.norm(c))
        moving = modes.T - rigid @ (rigid.T @ modes.T)
        independent = len(modes) and np.linalg.matrix_rank(moving, tol=RIGID_RTOL * np.linalg.norm(modes)) == len(modes)
        if not independent or not np.all(residual <= GIVEN_MODE_RTOL):
            raise DomainError(
                "no_motion", "the tolerance report needs the design's zero modes, independent of the rigid motions."
            )
        if n * d - rank != z:
            raise DomainError(
                "no_motion",
                f"the frame has {n * d - rank} zero modes, not the {z} of its rigid motions and designed modes.",
            )
        edge_vectors = x.reshape(n, d)[edges[:, 0]] - x.reshape(n, d)[edges[:, 1]]
        return cls(
            x, edges, n, d, modes, c, u_svd, s_pad, vt, np.linalg.pinv(c, rcond=RANK_RTOL), rigid,
            u_svd[:, rank:], np.linalg.norm(edge_vectors, axis=1), z, n * d - z - 1,
        )

    @property
    def mean_length(self) -> float:
        return float(self.lengths.mean())

    def compat(self, u: np.ndarray) -> np.ndarray:
        """C(u): the compatibility matrix with u in place of the positions (C(x)u = C(u)x)."""
        return compatibility_matrix(u.reshape(self.n, self.d), self.edges, dense=True)

    def mode_jacobian(self, u: np.ndarray) -> np.ndarray:
        """J_u = −C⁺ C(u): δu per δx for the zero mode u (dN × dN)."""
        return -self.pinv @ self.compat(u)

    def rows(self, nodes) -> np.ndarray:
        return (np.asarray(nodes, dtype=int)[:, None] * self.d + np.arange(self.d)).ravel()


@dataclass(frozen=True, eq=False)
class _Perturbed:
    """A built frame: x' (dN,), its soft subspace (dN × z), λ = σ²_{z+1} and the z smallest
    eigenvalues of C(x')ᵀC(x')."""

    x: np.ndarray
    soft: np.ndarray
    margin: float
    soft_eigenvalues: np.ndarray

    @classmethod
    def at(cls, design: _Design, x: np.ndarray) -> _Perturbed:
        """From the eigen-decomposition of CᵀC (λ = σ²; 3–5× cheaper than the SVD of C): its
        round-off, ~1e-16·λ_max, is far below the margins of designed frames (σ_r/σ_max ≳ 1e-4)
        and the soft eigenvalues the Monte Carlo measures (≳ 1e-3 of the margin)."""
        c = compatibility_matrix(x.reshape(design.n, design.d), design.edges, dense=True)
        lam, vectors = np.linalg.eigh(c.T @ c)  # ascending
        z = design.z
        return cls(x, vectors[:, :z], float(lam[z]), np.clip(lam[:z], 0.0, None))


@dataclass(frozen=True, eq=False)
class _Quantity:
    """A relative quantity: its Jacobian J (m × dN) w.r.t. the normalised δx, whether it is
    quadratic (mode_stiffness), and its exact change at a built frame (a _Perturbed → float)."""

    name: str
    jacobian: np.ndarray
    quadratic: bool
    change: Callable[[_Perturbed], float]


def _mode_quantity(design: _Design, nodes) -> _Quantity:
    """mode: ‖(I − P_D) u_D‖/‖u_D‖ over the modes, D = ``nodes``."""
    rows = design.rows(nodes)
    total = float(np.sqrt(np.sum(design.modes[:, rows] ** 2)))

    def residual(basis_d: np.ndarray, vectors: np.ndarray) -> np.ndarray:
        return vectors - basis_d @ (np.linalg.pinv(basis_d) @ vectors)

    basis_d = design.vt[-design.z :].T[rows]
    jac = np.vstack([residual(basis_d, design.mode_jacobian(u)[rows]) for u in design.modes]) / total
    return _Quantity(
        "mode", jac, False, lambda p: float(np.linalg.norm(residual(p.soft[rows], design.modes[:, rows].T)) / total)
    )


def _rigid_generators(x: np.ndarray, d: int) -> np.ndarray:
    """G (dN × ρ): the d translations and the rotations g_ab(x)_i = E_ab x_i, unnormalised."""
    n = len(x) // d
    y = x.reshape(n, d)
    cols = []
    for a in range(d):
        t = np.zeros((n, d))
        t[:, a] = 1.0
        cols.append(t.ravel())
    for a in range(d):
        for b in range(a + 1, d):
            r = np.zeros((n, d))
            r[:, a], r[:, b] = -y[:, b], y[:, a]
            cols.append(r.ravel())
    return np.column_stack(cols)


def _poisson_quantity(design: _Design, boundary) -> _Quantity:
    """poisson_ratio: |δν|/|ν| of the designed mode modulo rigid motions (module docstring)."""
    n, d = design.n, design.d
    u = design.modes[0] - design.rigid @ (design.rigid.T @ design.modes[0])  # Gᵀu = 0
    functionals = []
    for lo, hi, axis in (("left", "right", 0), ("bottom", "top", 1)):
        a = np.zeros((n, d))
        a[list(boundary[hi]), axis] += 1.0 / len(boundary[hi])
        a[list(boundary[lo]), axis] -= 1.0 / len(boundary[lo])
        functionals.append(a.ravel())
    a_x, a_y = functionals
    g = _rigid_generators(design.x, d)
    h = -_rigid_generators(u, d).T
    h[:d] = 0.0  # translations do not depend on x
    du = design.mode_jacobian(u) - g @ np.linalg.solve(g.T @ g, h)  # δ(P⊥u) per δx
    grad = a_y @ du / (a_y @ u) - a_x @ du / (a_x @ u) + a_x / (a_x @ design.x) - a_y / (a_y @ design.x)
    nu = poisson_ratio(design.x.reshape(n, d), u.reshape(n, d), boundary)

    def change(p: _Perturbed) -> float:
        rigid = rigid_motions(p.x.reshape(n, d))
        moving = p.soft - rigid @ (rigid.T @ p.soft)
        mode = np.linalg.svd(moving, full_matrices=False)[0][:, 0]
        return abs(poisson_ratio(p.x.reshape(n, d), mode.reshape(n, d), boundary) / nu - 1.0)

    return _Quantity("poisson_ratio", grad[None, :], False, change)


def _target_quantity(design: _Design, source, target) -> _Quantity:
    """target_response: ‖δw_T‖/‖w_T‖, w = N N_S⁺ u_S driven by the first mode's source rows."""
    src, tgt = design.rows(source), design.rows(target)
    u = design.modes[0]
    soft = design.vt[-design.z :].T
    jac = design.mode_jacobian(u)
    ref = float(np.linalg.norm(u[tgt]))

    def change(p: _Perturbed) -> float:
        w = p.soft[tgt] @ np.linalg.lstsq(p.soft[src], u[src], rcond=None)[0]
        return float(np.linalg.norm(w - u[tgt]) / ref)

    return _Quantity("target_response", (jac[tgt] - soft[tgt] @ np.linalg.pinv(soft[src]) @ jac[src]) / ref, False, change)


def _margin_quantity(design: _Design) -> _Quantity:
    """rigidity_margin: |δλ|/λ, λ = σ²_{z+1}, δσ = yᵀ C(v) δx."""
    k = design.margin_index
    sigma = design.s_pad[k]
    grad = design.u_svd[:, k] @ design.compat(design.vt[k])
    return _Quantity("rigidity_margin", (2 * grad / sigma)[None, :], False, lambda p: abs(p.margin / sigma**2 - 1.0))


def _stiffness_quantity(design: _Design) -> _Quantity:
    """mode_stiffness: Σ_m ‖C(x')û_m‖²/λ ≈ ‖Σᵀ C(Û) δx‖²/λ (frames with self-stresses)."""
    soft = design.vt[-design.z :].T
    moving = soft - design.rigid @ (design.rigid.T @ soft)
    u_hat = np.linalg.svd(moving, full_matrices=False)[0][:, : len(design.modes)]
    sigma = design.s_pad[design.margin_index]
    jac = np.vstack([design.stresses.T @ design.compat(u) for u in u_hat.T]) / sigma
    return _Quantity("mode_stiffness", jac, True, lambda p: float(np.sum(p.soft_eigenvalues) / p.margin))


def _estimate(design: _Design, q: _Quantity, error: str, b: np.ndarray, budget, samples, rng) -> ToleranceEstimate:
    """The linear tolerance of one quantity under one kind of error, checked by Monte Carlo."""
    norm = float(np.linalg.norm(q.jacobian @ b))
    sensitivity = float(norm**2 / 3 if q.quadratic else norm / np.sqrt(3))
    if sensitivity <= INSENSITIVE:
        return ToleranceEstimate(q.name, error, sensitivity, None, None, None, None, None, None)
    tol = float(np.sqrt(budget / sensitivity) if q.quadratic else budget / sensitivity)
    tested = min(tol, MAX_ERROR)
    predicted = float(sensitivity * tested**2 if q.quadratic else sensitivity * tested)
    changes, failed = [], 0
    for k in range(samples):
        check_budget()
        report_progress(k / samples, "Monte Carlo samples")
        built = _built(design, error, tested, rng)
        if built is None:
            failed += 1
            continue
        changes.append(q.change(_Perturbed.at(design, built)))
    if not changes:
        return ToleranceEstimate(q.name, error, sensitivity, tol, tested, predicted, None, None, False, failed)
    values = np.asarray(changes)
    stat = float(values.mean() if q.quadratic else np.sqrt(np.mean(values**2)))
    agrees = failed == 0 and predicted / AGREEMENT_FACTOR <= stat <= predicted * AGREEMENT_FACTOR
    return ToleranceEstimate(
        q.name, error, sensitivity, tol, tested, predicted, stat, float(np.quantile(values, 0.95)), bool(agrees), failed
    )


def _built(design: _Design, error: str, eps: float, rng) -> np.ndarray | None:
    """One built frame x' (normalised, flattened) with errors of size ε, or None when a frame
    with those bar lengths cannot be assembled near the design. A frame with perturbed lengths
    is assembled by Gauss–Newton on ½(|x_i − x_j|² − ℓ'²) = 0 with its displacement kept ⟂ the
    design's zero modes (x' = x + Kᵀa, K the other right singular vectors of C): as in the
    linearisation, where the mechanism sits along its motion is not an error, and the soft
    direction would otherwise take the least-squares steps of an incompatible assembly."""
    if error == "pin_positions":
        return design.x + eps * design.mean_length * rng.uniform(-1.0, 1.0, len(design.x))
    target = (design.lengths * (1.0 + eps * rng.uniform(-1.0, 1.0, len(design.lengths)))) ** 2
    complement = design.vt[: len(design.x) - design.z]  # (dN − z, dN)
    x = design.x.copy()
    e, n, d = design.edges, design.n, design.d
    for _ in range(ASSEMBLY_STEPS):
        y = x.reshape(n, d)
        f = 0.5 * (np.sum((y[e[:, 0]] - y[e[:, 1]]) ** 2, axis=1) - target)
        jac = compatibility_matrix(y, e, dense=True) @ complement.T  # σ_min ≥ the margin: well posed
        step = complement.T @ np.linalg.solve(jac.T @ jac, jac.T @ f)
        x = x - step
        if np.linalg.norm(step) <= ASSEMBLY_TOL * np.sqrt(n):
            return x
    return None
