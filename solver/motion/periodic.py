"""Finite motion of a periodic frame, one cell at a time, verified on the whole frame.

A periodic frame (an auxetic sheet tiled from one module, a chain of identical blocks) is a
cell of n_c nodes p_i with k lattice vectors L_a (k ≤ d), repeated at the cells c ∈ Z^k: node i
of cell c sits at p_i + Σ_a c_a L_a.  A bar e joins node i of cell 0 to node j of cell m_e:

    b_e = p_j + Σ_a m_{e,a} L_a − p_i,        g_e = ½(|b_e|² − ℓ_e²) = 0.

The cell's configuration (p, L) — the lattice free to deform, which is the strain of a sheet —
carries the periodic motions of every patch tiled from it.  Its Jacobian row e holds −b_e at
p_i, +b_e at p_j and m_{e,a} b_e at L_a (the compatibility matrix of the periodic frame with a
flexible lattice, Borcea & Streinu); its trivial motions are the translations of the nodes (L
fixed) and the rotations of everything, ρ = d(d+1)/2.  The cell is followed by the
continuation of finite_motion (the same predictor–corrector, determinant test and located,
confirmed singular points) on a system of (n_c + k)·d unknowns, whatever the number of cells,
in coordinates where distances are the patch's (PeriodicConstraints): the path parameter,
``amplitude`` and ``max_step`` mean what they mean for the patch's own continuation.

A patch tiled from the cell (``tiling``: node ↦ (cell node i, cell c)) moves with the cell: every
bar of the patch is a translate of a cell bar, so each tiled configuration keeps every bar
length.  That this periodic motion is *the* motion of the patch is checked on the patch itself
(``tiled_motion``): its bar lengths at every configuration, one nontrivial zero mode at the
reference, the tiled cell tangent in N(C) of the patch at every configuration, and the sign of
det [[C_kᵀC(X_{k+1}), W_k], [W_kᵀ, 0]] between consecutive configurations with W_k = the tiled
tangent ⊕ rigid motions (finite_motion's singular-point test, on the whole patch: a non-periodic
branch point between two configurations changes it).

A frame given without its tiling (/v1/motion's lattices) is recognised by find_tiling (periods
from its geometry and bars) and followed by trace_motion_through_cell: the cell's motion,
checked as above, or — wherever the guess or a check fails — the frame's own continuation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from zeromode.solver.analysis.bordered import BorderedFactor
from zeromode.solver.analysis.normalisation import Normalisation, rms_radius
from zeromode.solver.analysis.rank import (
    RTOL,
    complement_within,
    decide_rank,
    nullspace,
    orthonormal_range,
)
from zeromode.solver.analysis.rigidity import DENSE_MAX_DOF, rigid_motions
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import (
    BarConstraints,
    MotionPath,
    Singularity,
    align_to,
    bar_lengths,
    bracket_sign_change,
    check_trace_arguments,
    curve_chart,
    follow,
    given_mode,
    located_sigma,
    relative_bar_error,
    signed_determinant,
    signed_mode,
    start_direction,
    trace_motion,
)
from zeromode.solver.progress import progress_stage, report_progress
from zeromode.solver.tolerances import (
    DESIGN_MODE_RTOL,
    GIVEN_MODE_RTOL,
    PERIOD_INDEPENDENT_RTOL,
    SINGULAR_RTOL,
    TILING_RTOL,
)

# find_tiling tries the vectors to this many nodes of the central node's degree as periods (a
# 2D sheet has about 25 such nodes within two periods of any node).
CANDIDATE_PERIODS = 32
# ... ranked by how many of the LOCAL_NODES nodes nearest the central node they map onto nodes
# (all of them for a period of a patch several periods wide, over half for a patch two periods
# wide), then by length; below MIN_LOCAL_SHARE of them a candidate is no period worth a cell.
LOCAL_NODES = 256
MIN_LOCAL_SHARE = 0.5
# The cell's continuation is cheap: where ``stop`` turns true, its last step is shortened by
# this many bisections (to 2⁻³⁰ of a step), so the patch's path ends where the predicate does
# (e.g. at the end of a strain range) rather than up to a step past it.
STOP_BISECTIONS = 30
# Progress of trace_motion_through_cell: the frame's zero modes at the reference up to
# CHECK_SHARE, the cell's continuation up to CELL_SHARE, then the check of every configuration.
CHECK_SHARE = 0.1
CELL_SHARE = 0.15
# Codes by which the periodic route says the frame is not (verifiably) tiled: the frame's own
# continuation answers instead.
NOT_TILED = frozenset({"not_periodic", "invalid_tiling", "invalid_cell"})


@dataclass(frozen=True, eq=False)
class PeriodicCell:
    """positions (n_c, d) of the cell's nodes; lattice (k, d) its period vectors; edges (m, 2)
    cell-node indices; offsets (m, k) integers: bar e joins node edges[e, 0] of cell 0 to node
    edges[e, 1] of cell offsets[e]."""

    positions: np.ndarray
    lattice: np.ndarray
    edges: np.ndarray
    offsets: np.ndarray

    @classmethod
    def from_frame(cls, frame: Frame, tiling, lattice) -> PeriodicCell:
        """The cell of a frame tiled by ``tiling`` (N, 1 + k): row n = (cell node i, c_1 … c_k)
        of node n, with ``lattice`` (k, d).  The cell's nodes are placed at their tile's
        position minus c·L; every bar becomes one cell bar (repeated ones merged).
        InvalidInput when the nodes or bars are not translates of one cell."""
        tiling = np.asarray(tiling, dtype=int)
        lattice = np.atleast_2d(np.asarray(lattice, dtype=float))
        if tiling.shape != (frame.n_nodes, 1 + lattice.shape[0]):
            raise InvalidInput(
                "invalid_tiling",
                f"tiling must have one row (cell node, {lattice.shape[0]} cell indices) per node.",
            )
        node, cell = tiling[:, 0], tiling[:, 1:]
        n_c = int(node.max()) + 1
        origin = frame.positions - cell @ lattice
        positions = np.zeros((n_c, frame.dim))
        positions[node] = origin
        size = float(np.max(np.abs(frame.positions))) or 1.0
        if not np.allclose(origin, positions[node], rtol=0, atol=TILING_RTOL * size):
            raise InvalidInput("invalid_tiling", "the nodes are not translates of one cell.")
        i, j = frame.edges[:, 0], frame.edges[:, 1]
        offsets = cell[j] - cell[i]
        keys = np.column_stack([node[i], node[j], offsets])
        # A bar and its reverse are the same cell bar: (i, j, m) ~ (j, i, −m).
        flipped = np.column_stack([node[j], node[i], -offsets])
        canonical = np.where(
            (_lexicographic_less(flipped, keys))[:, None], flipped, keys
        )
        unique = np.unique(canonical, axis=0)
        return cls(positions, lattice, unique[:, :2], unique[:, 2:])

    def tile(self, positions: np.ndarray, lattice: np.ndarray, tiling) -> np.ndarray:
        """Positions (N, d) of the patch for a cell configuration (positions (n_c, d), lattice)."""
        tiling = np.asarray(tiling, dtype=int)
        return positions[tiling[:, 0]] + tiling[:, 1:] @ lattice


def _lexicographic_less(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a < b in lexicographic order, for integer arrays of equal shape."""
    diff = a - b
    first = np.argmax(diff != 0, axis=1)
    return diff[np.arange(len(diff)), first] < 0


class PeriodicConstraints(BarConstraints):
    """The cell's bar constraints in the patch's metric, dense.

    With T (N × m, m = n_c + k) the tiling matrix of the patch (row n: 1 at its cell node i(n),
    c_n at the lattice columns), the patch is X = T y for the cell's y = [p; L] (m × d).  With
    T = QR (thin QR; R regular when every cell node occurs and the cells span k directions),

        z = R (y − [X̄; 0]) / r,        X̄ the patch's centroid, r its RMS radius,

    ‖δz‖_F = ‖T δy‖_F / r: distances in z are the patch's normalised distances.  Continuation in z
    is therefore the patch's own continuation restricted to periodic motions: the same
    pseudo-arclength (``measured_nodes`` = N) and the same gauge (the tiled translations and
    rotations are the patch's).  Bars: b_e = B z with B = D R⁻¹ (D: −1 at i_e, +1 at j_e, m_e at the
    lattice columns), so row e of the Jacobian holds B_e ⊗ b_e."""

    def __init__(self, cell: PeriodicCell, tiling: np.ndarray):
        self.cell = cell
        self.n_cell, k = len(cell.positions), len(cell.lattice)
        tiling = np.asarray(tiling, dtype=int)
        m = self.n_cell + k
        t = np.zeros((len(tiling), m))
        t[np.arange(len(tiling)), tiling[:, 0]] = 1.0
        t[:, self.n_cell :] = tiling[:, 1:]
        self.r_factor = np.linalg.qr(t, mode="r")
        diag = np.abs(np.diag(self.r_factor))
        if not diag.min() > RTOL * diag.max():
            raise DomainError("not_periodic", "the tiling does not determine the cell (its tiling matrix is singular).")
        y = np.vstack([cell.positions, cell.lattice])
        patch = t @ y
        self.shift = np.zeros_like(y)
        self.shift[: self.n_cell] = patch.mean(axis=0)
        self.scale = rms_radius(patch) or 1.0
        d_matrix = np.zeros((len(cell.edges), m))
        rows = np.arange(len(cell.edges))
        np.add.at(d_matrix, (rows, cell.edges[:, 0]), -1.0)
        np.add.at(d_matrix, (rows, cell.edges[:, 1]), 1.0)
        d_matrix[:, self.n_cell :] += cell.offsets
        self.bar_map = sla.solve_triangular(self.r_factor, d_matrix.T, trans="T").T  # D R⁻¹
        self.reference = self.z_of(cell.positions, cell.lattice)
        self.edges = cell.edges
        self.lengths = np.linalg.norm(self.bar_map @ self.reference, axis=1)
        if not np.all(self.lengths > 0):
            raise InvalidInput("invalid_cell", "a cell bar has zero length.")
        self.n, self.d = self.reference.shape
        self.measured_nodes = len(tiling)
        self.method = "dense"
        self.sigma_max = self.largest_singular_value(self.jacobian(self.reference))

    def z_of(self, positions: np.ndarray, lattice: np.ndarray) -> np.ndarray:
        """z (m, d) of the cell configuration (positions (n_c, d), lattice (k, d))."""
        return self.r_factor @ (np.vstack([positions, lattice]) - self.shift) / self.scale

    def cell_of(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(positions (n_c, d), lattice (k, d)) of z."""
        y = sla.solve_triangular(self.r_factor, z * self.scale) + self.shift
        return y[: self.n_cell], y[self.n_cell :]

    def rates_of(self, dz: np.ndarray) -> np.ndarray:
        """Cell rates δy = R⁻¹ δz (m × d) of a motion δz, up to the scale r."""
        return sla.solve_triangular(self.r_factor, dz)

    def residual(self, z: np.ndarray) -> np.ndarray:
        b = self.bar_map @ z
        return 0.5 * (np.sum(b * b, axis=1) - self.lengths**2)

    def error(self, z: np.ndarray) -> float:
        return float(np.max(np.abs(np.linalg.norm(self.bar_map @ z, axis=1) - self.lengths) / self.lengths))

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        b = self.bar_map @ z
        return (self.bar_map[:, :, None] * b[:, None, :]).reshape(len(b), -1)

    def rigid(self, z: np.ndarray) -> np.ndarray:
        """The patch's translations (nodes moved, lattice fixed) and rotations (of everything)."""
        translation = self.r_factor[:, : self.n_cell].sum(axis=1)
        generators = []
        for a in range(self.d):
            t = np.zeros((self.n, self.d))
            t[:, a] = translation
            generators.append(t.ravel())
        for a in range(self.d):
            for b in range(a + 1, self.d):
                r = np.zeros((self.n, self.d))
                r[:, a], r[:, b] = -z[:, b], z[:, a]
                generators.append(r.ravel())
        return orthonormal_range(np.column_stack(generators), RTOL)

    def count(self, z: np.ndarray, rtol: float) -> tuple[int, int, float, float]:
        s = np.linalg.svd(self.jacobian(z), compute_uv=False)
        rank, gap = decide_rank(s, rtol)
        zero = self.n * self.d - rank
        scale = float(s[0]) if s.size and s[0] > 0 else 1.0
        return zero, zero - self.rigid(z).shape[1], gap.last_nonzero / scale, gap.first_zero / scale

    def null_space(self, z: np.ndarray, nontrivial: int) -> np.ndarray:
        return nullspace(self.jacobian(z), RTOL)[0]

    def modes(self, z: np.ndarray) -> np.ndarray:
        """Orthonormal nontrivial zero modes (m·d × f) at z."""
        return complement_within(self.null_space(z, 0), self.rigid(z))


@dataclass(frozen=True, eq=False)
class PeriodicPath:
    """The cell's finite motion: positions (P, n_c, d) and lattice (P, k, d) in the frame's
    coordinates, ``parameter`` (P,) the pseudo-arclength of the tiled patch (trace_motion's
    units: RMS node displacement over the patch's RMS radius), 0 at index ``reference_index``;
    singular points of the cell's configuration space as in MotionPath."""

    positions: np.ndarray
    lattice: np.ndarray
    parameter: np.ndarray
    reference_index: int
    singularities: tuple[Singularity, ...]
    max_relative_bar_error: float


def trace_periodic_motion(
    cell: PeriodicCell,
    tiling,
    mode=None,
    amplitude: float = 0.2,
    max_step: float = 0.02,
    direction: str = "both",
    max_steps: int = 5000,
    stop=None,
) -> PeriodicPath:
    """Follow the periodic finite motion of ``cell`` tiled by ``tiling`` (see the module
    docstring and PeriodicConstraints: the parameter is the patch's).

    mode: ((n_c + k), d) rates of the nodes and lattice vectors, or None (the cell's single
    nontrivial mode, signed by finite_motion.signed_mode). stop(patch positions (N, d), sign): as
    finite_motion.trace_motion's, on the tiled patch, the last step shortened towards where it
    turns true (STOP_BISECTIONS). Other arguments as trace_motion.
    """
    tiling = np.asarray(tiling, dtype=int)
    cons = PeriodicConstraints(cell, tiling)
    z0 = cons.reference
    t0, null = start_direction(cons, z0, None if mode is None else cons.r_factor @ np.asarray(mode, float))
    until = None if stop is None else (lambda z, sign: stop(cell.tile(*cons.cell_of(z), tiling), sign))
    configs, params, ref, singularities = follow(
        cons, z0, t0, null, amplitude, max_step, direction, max_steps, until, STOP_BISECTIONS
    )
    cells = [cons.cell_of(z) for z in configs]
    return PeriodicPath(
        positions=np.stack([p for p, _ in cells]),
        lattice=np.stack([lat for _, lat in cells]),
        parameter=params,
        reference_index=ref,
        singularities=singularities,
        max_relative_bar_error=max(cons.error(z) for z in configs),
    )


def tiled_motion(
    frame: Frame,
    tiling,
    cell: PeriodicCell,
    path: PeriodicPath,
    check: _PatchCheck | None = None,
) -> MotionPath:
    """The patch ``frame`` (tiled from ``cell`` by ``tiling``) along the cell's ``path``, checked
    on the patch (module docstring), as a MotionPath with method "periodic": configurations
    aligned to the reference, singular points counted on the patch.

    Where the patch meets a singular point that its cell does not (a non-periodic branch, e.g.
    nodes of neighbouring cells that collide), the sign test between two configurations fails;
    the point is then located along the cell's curve by finite_motion's regula falsi on the
    patch's determinant, confirmed by counting the patch's zero modes, and ends the path in
    that direction. DomainError ``not_periodic`` when the patch does not move with its cell.
    ``check``: the patch's _PatchCheck, when the caller has built it already.  Progress: the
    share of configurations checked, each one's zero-mode count or singular point located in
    a stage of its own."""
    tiling = np.asarray(tiling, dtype=int)
    lengths = bar_lengths(frame.positions, frame.edges)
    configs = [cell.tile(p, lat, tiling) for p, lat in zip(path.positions, path.lattice)]
    error = max(relative_bar_error(x, frame.edges, lengths) for x in configs)
    if not error <= TILING_RTOL:
        raise DomainError(
            "not_periodic",
            f"the tiled configurations leave the frame's bars by {error:.2e}: the frame is not tiled from the cell.",
        )
    check = _PatchCheck(frame, tiling, cell) if check is None else check
    ref = path.reference_index
    cell_singular = {s.step: s for s in path.singularities}
    sides, done, at_reference = {}, 0, check.frame_at(path, ref, configs[ref])

    def stage(count: int, label: str):
        """The progress stage of the configuration after ``count`` checked ones."""
        total = max(len(configs) - 1, 1)
        return progress_stage(count / total, (count + 1) / total, label)

    for sign in (-1, 1):
        out, end = [], None  # out: (parameter, configuration) moving away from the reference
        previous = at_reference
        for k in range(ref + sign, -1 if sign < 0 else len(configs), sign):
            if k in cell_singular:
                with stage(done, "counting the frame's zero modes at the cell's singular point"):
                    extra, sigma = check.extra_zero_modes(configs[k])
                if extra <= 0 and cell_singular[k].kind == "rank_drop":
                    raise DomainError(
                        "not_periodic", "the cell's singular point is a regular configuration of the patch."
                    )
                out.append((path.parameter[k], configs[k]))
                end = (max(extra, 0), sigma, cell_singular[k].kind)
                break
            current = check.frame_at(path, k, configs[k])
            if not check.regular_between(previous, current):
                with stage(done, "locating a singular point"):
                    found = check.locate(previous, path, k - sign, k, report_progress)
                if found is not None:
                    parameter, x, extra, sigma = found
                    out.append((parameter, x))
                    end = (extra, sigma, "rank_drop")
                    break
            out.append((path.parameter[k], configs[k]))
            previous = current
            done += 1
            report_progress(done / max(len(configs) - 1, 1), "checking the tiled motion on the frame")
        sides[sign] = (out, end)
    (back, back_end), (fwd, fwd_end) = sides[-1], sides[1]
    entries = back[::-1] + [(path.parameter[ref], frame.positions)] + fwd
    singularities = []
    for end, step in ((back_end, 0), (fwd_end, len(entries) - 1)):
        if end is not None:
            singularities.append(Singularity(step, float(entries[step][0]), *end))
    return MotionPath(
        positions=np.stack(
            [x if i == len(back) else align_to(x, frame.positions) for i, (_, x) in enumerate(entries)]
        ),
        parameter=np.array([parameter for parameter, _ in entries]),
        reference_index=len(back),
        max_relative_bar_error=max(relative_bar_error(x, frame.edges, lengths) for _, x in entries),
        singularities=tuple(singularities),
        edges=frame.edges,
        method="periodic",
    )


class _PatchCheck:
    """The patch's side of tiled_motion: its zero modes, determinant and counts (normalised
    with the reference's map), and the cell's curve between two samples of its path."""

    def __init__(self, frame: Frame, tiling: np.ndarray, cell: PeriodicCell):
        self.frame, self.tiling, self.cell = frame, tiling, cell
        self.norm = Normalisation.of(frame.positions)
        x0 = self.norm.positions_in(frame.positions)
        method = "dense" if frame.dim * frame.n_nodes <= DENSE_MAX_DOF else "sparse"
        self.patch = BarConstraints(frame.edges, x0, method)
        zero, nontrivial, _, _ = self.patch.count(x0, RTOL)
        if nontrivial != 1:
            raise DomainError(
                "not_periodic",
                f"the frame has {nontrivial} nontrivial zero modes; the periodic motion is its "
                "motion only when it has one.",
            )
        self.zero_modes = zero
        self.cell_cons = PeriodicConstraints(cell, tiling)

    def tiled_mode(self, z: np.ndarray) -> np.ndarray:
        """The tiled cell mode (dN) and its cell rates ((n_c + k), d) at the cell's z; DomainError
        ``not_periodic`` unless the cell has exactly one nontrivial mode there."""
        modes = self.cell_cons.modes(z)
        if modes.shape[1] != 1:
            raise DomainError(
                "not_periodic", f"the cell has {modes.shape[1]} nontrivial zero modes on the path, not 1."
            )
        rates = self.cell_cons.rates_of(modes[:, 0].reshape(-1, self.frame.dim))
        n_c = len(self.cell.positions)
        return self.cell.tile(rates[:n_c], rates[n_c:], self.tiling).ravel(), rates

    def default_mode(self) -> np.ndarray:
        """The frame's nontrivial mode (N, d) as trace_motion picks it without one: the tiled
        cell mode ⟂ the rigid motions, signed by finite_motion.signed_mode."""
        u, _ = self.tiled_mode(self.cell_cons.reference)
        rigid = rigid_motions(self.norm.positions_in(self.frame.positions), RTOL)
        u = u - rigid @ (rigid.T @ u)
        return signed_mode(u).reshape(self.frame.positions.shape)

    def cell_rates(self, mode) -> np.ndarray:
        """The cell's rates ((n_c + k), d) of its mode, signed like the frame's ``mode`` (N, d);
        DomainError ``not_periodic`` unless ``mode`` lies in span(rigid motions, tiled mode) to
        within GIVEN_MODE_RTOL (then it is a zero mode: the frame has one nontrivial mode) with
        a part along the tiled mode; InvalidInput as trace_motion's for a mode of the wrong shape."""
        u, rates = self.tiled_mode(self.cell_cons.reference)
        m = given_mode(mode, self.frame.n_nodes, self.frame.dim).ravel()
        rigid = rigid_motions(self.norm.positions_in(self.frame.positions), RTOL)
        span = np.linalg.qr(np.column_stack([u, rigid]))[0]
        norm = np.linalg.norm(m)
        along = float(u @ (m - rigid @ (rigid.T @ m))) / np.linalg.norm(u)
        leak = np.linalg.norm(m - span @ (span.T @ m))
        if not (leak <= GIVEN_MODE_RTOL * norm and abs(along) > GIVEN_MODE_RTOL * norm):
            raise DomainError("not_periodic", "the given mode is not the tiled cell's mode.")
        return rates * np.sign(along)

    def frame_at(self, path: PeriodicPath, k: int, x: np.ndarray):
        """(C(x), W) of the patch at its k-th configuration x: W = [tiled cell tangent, rigid
        motions] orthonormal, after checking that the tiled tangent is a zero mode there."""
        u, _ = self.tiled_mode(self.cell_cons.z_of(path.positions[k], path.lattice[k]))
        xn = self.norm.positions_in(x)
        c = self.patch.jacobian(xn)
        residual = np.linalg.norm(c @ u) / (_frobenius(c) * np.linalg.norm(u))
        if not residual <= DESIGN_MODE_RTOL:
            raise DomainError(
                "not_periodic", f"the tiled cell motion leaves the patch's zero modes by {residual:.2e}."
            )
        return c, np.linalg.qr(np.column_stack([u, rigid_motions(xn, RTOL)]))[0]

    def regular_between(self, start, end) -> bool:
        """sign det [[C_kᵀ C(X), W_k], [W_kᵀ, 0]] = (−1)^z at the end: no singular point between."""
        (c_k, w_k), (c_end, _) = start, end
        return BorderedFactor(c_k.T @ c_end, w_k).sign == _regular_sign(w_k)

    def extra_zero_modes(self, x: np.ndarray) -> tuple[int, float]:
        """(zero modes of the patch at x beyond the reference's, σ/σ_max of the vanishing one)."""
        xn = self.norm.positions_in(x)
        count, _, last_nonzero, first_zero = self.patch.count(xn, SINGULAR_RTOL)
        extra = count - self.zero_modes
        return extra, first_zero if extra > 0 else last_nonzero

    def locate(self, start, path: PeriodicPath, k0: int, k1: int, report=None):
        """The patch's singular point between samples k0 and k1 of the cell's path, along the
        cell's curve: (parameter, configuration, extra zero modes, σ) or None (not confirmed);
        ``report`` as bracket_sign_change's."""
        c_k, w_k = start
        sign = _regular_sign(w_k)
        reference = BorderedFactor(c_k.T @ c_k, w_k).logabsdet
        cons = self.cell_cons
        z0 = cons.z_of(path.positions[k0], path.lattice[k0])
        z1 = cons.z_of(path.positions[k1], path.lattice[k1])
        chart = curve_chart(cons, z0, (z1 - z0).ravel())
        h = abs(float(path.parameter[k1] - path.parameter[k0]))

        def evaluate(s, lo, state_lo):
            z = chart(s, None if state_lo is None else state_lo[0])
            if z is None:
                return None
            x = self.cell.tile(*cons.cell_of(z), self.tiling)
            xn = self.norm.positions_in(x)
            c = self.patch.jacobian(xn)
            try:
                factor = BorderedFactor(c_k.T @ c, w_k)
            except np.linalg.LinAlgError:  # exactly on it
                return None, (z, x, xn, c, None)
            return signed_determinant(factor, sign, reference), (z, x, xn, c, factor)

        def measure(state) -> float:
            _, _, xn, c, factor = state
            return located_sigma(self.patch, xn, c, factor, self.zero_modes)

        end = evaluate(h, 0.0, None)
        if end is None or end[0] is not None and end[0] > 0:
            return None
        if end[0] is None:
            s_star, x_star = h, end[1][1]
        else:
            _, s_star, (_, x_star, _, _, _) = bracket_sign_change(evaluate, measure, h, end[0], end[1], report)
        extra, sigma = self.extra_zero_modes(x_star)
        if extra <= 0:
            return None
        direction = 1.0 if path.parameter[k1] > path.parameter[k0] else -1.0
        return float(path.parameter[k0] + direction * s_star), x_star, extra, sigma


def _regular_sign(w: np.ndarray) -> int:
    """(−1)^z, z = dim W: sign det [[CᵀC, W], [Wᵀ, 0]] when W spans N(C)."""
    return -1 if w.shape[1] % 2 else 1


def _frobenius(c) -> float:
    return float(np.sqrt(c.multiply(c).sum())) if hasattr(c, "multiply") else float(np.linalg.norm(c))


# ----------------------------------------------------------------------------------------------
# Recognising a tiled frame, and the motion of a frame through its cell


def find_tiling(frame: Frame) -> tuple[np.ndarray, np.ndarray] | None:
    """A guess at how ``frame`` is tiled by translations: (tiling (N, 1 + k), lattice (k, d)) for
    PeriodicCell.from_frame, or None.

    Candidate periods are the vectors t from the node nearest the centroid to the
    CANDIDATE_PERIODS nearest nodes of its degree, ranked by how many of its LOCAL_NODES nearest
    nodes have a translate x + t among the nodes (within TILING_RTOL of the frame's size; at
    least MIN_LOCAL_SHARE of them), then by length.  In that order, a candidate independent of
    the periods taken is a period when every bar whose two ends have translates maps onto a bar
    (checked on the whole frame), up to d periods.  The nodes then fall into
    orbits (connected by the periods): each orbit is one node of the cell, and c_n, the integer
    coordinates of x_n − x_root in the lattice, places node n.  Only a guess: from_frame checks
    the positions, tiled_motion the motion on the whole frame."""
    x, n = frame.positions, frame.n_nodes
    if n < 2 or len(frame.edges) == 0:
        return None
    tol = TILING_RTOL * float(np.max(np.abs(x)))
    tree = cKDTree(x)
    edges = np.sort(frame.edges, axis=1)
    keys = np.unique(edges[:, 0] * n + edges[:, 1])
    degree = np.bincount(frame.edges.ravel(), minlength=n)
    anchor = int(np.argmin(np.sum((x - x.mean(axis=0)) ** 2, axis=1)))
    same = np.flatnonzero((degree == degree[anchor]) & (np.arange(n) != anchor))
    if same.size == 0:
        return None
    near = same[cKDTree(x[same]).query(x[anchor], k=min(CANDIDATE_PERIODS, same.size))[1]]
    local = tree.query(x[anchor], k=min(LOCAL_NODES, n))[1]
    candidates = []  # (−share of the anchor's neighbourhood mapped, length, t)
    for j in np.atleast_1d(near):
        t = x[j] - x[anchor]
        hits = np.count_nonzero(np.isfinite(tree.query(x[local] + t, distance_upper_bound=tol)[0]))
        if hits >= MIN_LOCAL_SHARE * len(local):
            candidates.append((-hits, float(np.linalg.norm(t)), t))
    candidates.sort(key=lambda c: c[:2])
    lattice, images = [], []
    for _, _, t in candidates:
        if lattice and not _independent(np.array(lattice + [t])):
            continue
        dist, image = tree.query(x + t, distance_upper_bound=tol)
        image = np.where(np.isfinite(dist), image, -1)
        both = (image[edges[:, 0]] >= 0) & (image[edges[:, 1]] >= 0)
        mapped = np.sort(image[edges[both]], axis=1)
        if np.isin(mapped[:, 0] * n + mapped[:, 1], keys).all():
            lattice.append(t)
            images.append(image)
        if len(lattice) == frame.dim:
            break
    if not lattice:
        return None
    lattice = np.array(lattice)
    source = np.concatenate([np.flatnonzero(image >= 0) for image in images])
    target = np.concatenate([image[image >= 0] for image in images])
    graph = sp.coo_matrix((np.ones(source.size), (source, target)), shape=(n, n))
    n_cell, orbit = connected_components(graph, directed=False)
    root = np.full(n_cell, n)
    np.minimum.at(root, orbit, np.arange(n))
    cells = np.linalg.lstsq(lattice.T, (x - x[root[orbit]]).T, rcond=None)[0].T
    return np.column_stack([orbit, np.rint(cells).astype(int)]), lattice


def _independent(rows: np.ndarray) -> bool:
    """Whether the rows are linearly independent (smallest singular value above
    PERIOD_INDEPENDENT_RTOL of the largest)."""
    s = np.linalg.svd(rows, compute_uv=False)
    return bool(s[-1] > PERIOD_INDEPENDENT_RTOL * s[0])


def trace_motion_through_cell(
    frame: Frame,
    mode=None,
    amplitude: float = 0.2,
    max_step: float = 0.02,
    direction: str = "both",
    max_steps: int = 5000,
    stop=None,
) -> MotionPath:
    """finite_motion.trace_motion (same arguments, same MotionPath), through one cell when
    ``frame`` is tiled: find_tiling's guess, the cell's motion traced (trace_periodic_motion,
    the patch's parameter) and checked on the whole frame (tiled_motion: every bar at every
    configuration within TILING_RTOL, the tiled tangent in N(C), the determinant test), method
    "periodic".  Wherever the frame is not recognised, or a check fails, the frame's own
    continuation answers instead.

    A given ``mode`` must lie in span(rigid motions, tiled cell tangent) to within
    GIVEN_MODE_RTOL (then it is a zero mode, and its sign picks the direction); any other mode
    goes to trace_motion, which decides it."""
    check_trace_arguments(frame, amplitude, max_step, direction)
    full = {
        "mode": mode, "amplitude": amplitude, "max_step": max_step,
        "direction": direction, "max_steps": max_steps, "stop": stop,
    }
    guess = None if frame.dim * frame.n_nodes <= DENSE_MAX_DOF else find_tiling(frame)
    if guess is None:
        return trace_motion(frame, **full)
    tiling, lattice = guess
    reached = 0.0  # the end of the last progress stage entered: a fallback starts there
    try:
        cell = PeriodicCell.from_frame(frame, tiling, lattice)
        reached = CHECK_SHARE
        with progress_stage(0.0, CHECK_SHARE, "the frame's zero modes"):
            check = _PatchCheck(frame, tiling, cell)
            cell_mode = check.cell_rates(check.default_mode() if mode is None else mode)
        reached = CELL_SHARE
        with progress_stage(CHECK_SHARE, CELL_SHARE, "its cell's motion"):
            path = trace_periodic_motion(cell, tiling, cell_mode, amplitude, max_step, direction, max_steps, stop)
        reached = 1.0
        with progress_stage(CELL_SHARE, 1.0, "checked on the frame"):
            return tiled_motion(frame, tiling, cell, path, check)
    except (DomainError, InvalidInput) as exc:
        if exc.code not in NOT_TILED:
            raise
    with progress_stage(reached, 1.0, "the frame's own continuation"):
        return trace_motion(frame, **full)
