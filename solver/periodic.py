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
confirmed singular points) on a system of (n_c + k)·d unknowns, whatever the number of cells.

A patch tiled from the cell (``tiling``: node ↦ (cell node i, cell c)) moves with the cell: every
bar of the patch is a translate of a cell bar, so each tiled configuration keeps every bar
length.  That this periodic motion is *the* motion of the patch is checked on the patch itself
(``tiled_motion``): its bar lengths at every configuration, one nontrivial zero mode at the
reference, the tiled cell tangent in N(C) of the patch at every configuration, and the sign of
det [[C_kᵀC(X_{k+1}), W_k], [W_kᵀ, 0]] between consecutive configurations with W_k = the tiled
tangent ⊕ rigid motions (finite_motion's singular-point test, on the whole patch: a non-periodic
branch point between two configurations changes it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.bordered import BorderedFactor
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.finite_motion import (
    SINGULAR_RTOL,
    BarConstraints,
    MotionPath,
    Singularity,
    align_to,
    bar_lengths,
    bracket_sign_change,
    curve_chart,
    follow,
    located_sigma,
    relative_bar_error,
    signed_determinant,
    start_direction,
)
from zeromode.solver.frame import Frame
from zeromode.solver.normalisation import Normalisation
from zeromode.solver.rank import RTOL, complement_within, decide_rank, nullspace, orthonormal_range
from zeromode.solver.rigidity import DENSE_MAX_DOF, rigid_motions
from zeromode.solver.tolerances import DESIGN_MODE_RTOL

# A tiled configuration whose bars are off by more than this (relative) is not a translate of
# the cell's: the frame is not the tiling it was said to be.
TILING_RTOL = 1e-9


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
    """The cell's bar constraints on y = [p; L] ((n_c + k) × d, normalised), dense."""

    def __init__(self, cell: PeriodicCell, reference: np.ndarray):
        self.cell = cell
        self.n_cell = len(cell.positions)
        self.edges = cell.edges
        self.lengths = np.linalg.norm(self._bars(reference), axis=1)
        if not np.all(self.lengths > 0):
            raise InvalidInput("invalid_cell", "a cell bar has zero length.")
        self.n, self.d = reference.shape
        self.method = "dense"
        self.sigma_max = self.largest_singular_value(self.jacobian(reference))

    def _bars(self, y: np.ndarray) -> np.ndarray:
        p, lat = y[: self.n_cell], y[self.n_cell :]
        return p[self.edges[:, 1]] + self.cell.offsets @ lat - p[self.edges[:, 0]]

    def residual(self, y: np.ndarray) -> np.ndarray:
        b = self._bars(y)
        return 0.5 * (np.sum(b * b, axis=1) - self.lengths**2)

    def error(self, y: np.ndarray) -> float:
        return float(np.max(np.abs(np.linalg.norm(self._bars(y), axis=1) - self.lengths) / self.lengths))

    def jacobian(self, y: np.ndarray) -> np.ndarray:
        b = self._bars(y)
        m = len(b)
        jac = np.zeros((m, self.n, self.d))
        rows = np.arange(m)
        np.add.at(jac, (rows, self.edges[:, 0]), -b)
        np.add.at(jac, (rows, self.edges[:, 1]), b)
        jac[:, self.n_cell :, :] += self.cell.offsets[:, :, None] * b[:, None, :]
        return jac.reshape(m, -1)

    def rigid(self, y: np.ndarray) -> np.ndarray:
        """Translations of the nodes (lattice fixed) and rotations of nodes and lattice."""
        generators = []
        for a in range(self.d):
            t = np.zeros((self.n, self.d))
            t[: self.n_cell, a] = 1.0
            generators.append(t.ravel())
        for a in range(self.d):
            for b in range(a + 1, self.d):
                r = np.zeros((self.n, self.d))
                r[:, a], r[:, b] = -y[:, b], y[:, a]
                generators.append(r.ravel())
        return orthonormal_range(np.column_stack(generators), RTOL)

    def count(self, y: np.ndarray, rtol: float) -> tuple[int, int, float, float]:
        jac = self.jacobian(y)
        s = np.linalg.svd(jac, compute_uv=False)
        rank, gap = decide_rank(s, rtol)
        zero = self.n * self.d - rank
        scale = float(s[0]) if s.size and s[0] > 0 else 1.0
        return zero, zero - self.rigid(y).shape[1], gap.last_nonzero / scale, gap.first_zero / scale

    def null_space(self, y: np.ndarray, nontrivial: int) -> np.ndarray:
        return nullspace(self.jacobian(y), RTOL)[0]


@dataclass(frozen=True, eq=False)
class PeriodicPath:
    """The cell's finite motion: positions (P, n_c, d) and lattice (P, k, d) in the cell's
    coordinates, ``parameter`` (P,) the pseudo-arclength of the cell's rows (nodes and lattice
    vectors) in units of their RMS displacement over the cell's RMS radius, 0 at index
    ``reference_index``; singular points of the cell's configuration space as in MotionPath."""

    positions: np.ndarray
    lattice: np.ndarray
    parameter: np.ndarray
    reference_index: int
    singularities: tuple[Singularity, ...]
    max_relative_bar_error: float


def trace_periodic_motion(
    cell: PeriodicCell,
    mode=None,
    amplitude: float = 0.2,
    max_step: float = 0.02,
    direction: str = "both",
    max_steps: int = 5000,
) -> PeriodicPath:
    """Follow the periodic finite motion of ``cell`` (see the module docstring).

    mode: ((n_c + k), d) rates of the nodes and lattice vectors, or None (the cell's single
    nontrivial mode, largest entry positive). Other arguments as finite_motion.trace_motion.
    """
    n_c = len(cell.positions)
    norm = Normalisation.of(cell.positions)
    y0 = np.vstack([norm.positions_in(cell.positions), cell.lattice / norm.length])
    cons = PeriodicConstraints(cell, y0)
    t0, null = start_direction(cons, y0, None if mode is None else np.asarray(mode, float))
    configs, params, ref, singularities = follow(
        cons, y0, t0, null, amplitude, max_step, direction, max_steps
    )
    ys = np.stack(configs)
    return PeriodicPath(
        positions=norm.positions_out(ys[:, :n_c]),
        lattice=ys[:, n_c:] * norm.length,
        parameter=params,
        reference_index=ref,
        singularities=singularities,
        max_relative_bar_error=max(cons.error(y) for y in ys),
    )


def cell_modes(cell: PeriodicCell, positions: np.ndarray, lattice: np.ndarray) -> np.ndarray:
    """Orthonormal nontrivial zero modes ((n_c + k)·d × f) of the cell at a configuration."""
    norm = Normalisation.of(positions)
    y = np.vstack([norm.positions_in(positions), lattice / norm.length])
    cons = PeriodicConstraints(PeriodicCell(positions, lattice, cell.edges, cell.offsets), y)
    return complement_within(cons.null_space(y, 0), cons.rigid(y))


def tiled_motion(frame: Frame, tiling, cell: PeriodicCell, path: PeriodicPath) -> MotionPath:
    """The patch ``frame`` (tiled from ``cell`` by ``tiling``) along the cell's ``path``, checked
    on the patch (module docstring), as a MotionPath with method "periodic": configurations
    aligned to the reference, singular points counted on the patch.

    Where the patch meets a singular point that its cell does not (a non-periodic branch, e.g.
    nodes of neighbouring cells that collide), the sign test between two configurations fails;
    the point is then located along the cell's curve by finite_motion's regula falsi on the
    patch's determinant, confirmed by counting the patch's zero modes, and ends the path in
    that direction. DomainError ``not_periodic`` when the patch does not move with its cell."""
    tiling = np.asarray(tiling, dtype=int)
    lengths = bar_lengths(frame.positions, frame.edges)
    configs = [cell.tile(p, lat, tiling) for p, lat in zip(path.positions, path.lattice)]
    error = max(relative_bar_error(x, frame.edges, lengths) for x in configs)
    if not error <= TILING_RTOL:
        raise DomainError(
            "not_periodic",
            f"the tiled configurations leave the frame's bars by {error:.2e}: the frame is not tiled from the cell.",
        )
    check = _PatchCheck(frame, tiling, cell)
    ref = path.reference_index
    cell_singular = {s.step: s for s in path.singularities}
    sides = {}
    for sign in (-1, 1):
        out, end = [], None  # out: (parameter, configuration) moving away from the reference
        previous = check.frame_at(path, ref, configs[ref])
        for k in range(ref + sign, -1 if sign < 0 else len(configs), sign):
            if k in cell_singular:
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
                found = check.locate(previous, path, k - sign, k)
                if found is not None:
                    parameter, x, extra, sigma = found
                    out.append((parameter, x))
                    end = (extra, sigma, "rank_drop")
                    break
            out.append((path.parameter[k], configs[k]))
            previous = current
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
        self.cell_norm = Normalisation.of(cell.positions)
        self.cell_cons = PeriodicConstraints(cell, self.cell_y(cell.positions, cell.lattice))

    def cell_y(self, positions, lattice) -> np.ndarray:
        return np.vstack([self.cell_norm.positions_in(positions), lattice / self.cell_norm.length])

    def frame_at(self, path: PeriodicPath, k: int, x: np.ndarray):
        """(C(x), W) of the patch at its k-th configuration x: W = [tiled cell tangent, rigid
        motions] orthonormal, after checking that the tiled tangent is a zero mode there."""
        p, lat = path.positions[k], path.lattice[k]
        modes = cell_modes(self.cell, p, lat)
        if modes.shape[1] != 1:
            raise DomainError(
                "not_periodic", f"the cell has {modes.shape[1]} nontrivial zero modes on the path, not 1."
            )
        rates = modes[:, 0].reshape(-1, p.shape[1])
        u = self.cell.tile(rates[: len(p)], rates[len(p) :], self.tiling).ravel()
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

    def locate(self, start, path: PeriodicPath, k0: int, k1: int):
        """The patch's singular point between samples k0 and k1 of the cell's path, along the
        cell's curve: (parameter, configuration, extra zero modes, σ) or None (not confirmed)."""
        c_k, w_k = start
        sign = _regular_sign(w_k)
        reference = BorderedFactor(c_k.T @ c_k, w_k).logabsdet
        y0 = self.cell_y(path.positions[k0], path.lattice[k0])
        y1 = self.cell_y(path.positions[k1], path.lattice[k1])
        chart = curve_chart(self.cell_cons, y0, (y1 - y0).ravel())
        h = abs(float(path.parameter[k1] - path.parameter[k0]))
        n_c = len(self.cell.positions)

        def evaluate(s, lo, state_lo):
            y = chart(s, None if state_lo is None else state_lo[0])
            if y is None:
                return None
            x = self.cell.tile(
                self.cell_norm.positions_out(y[:n_c]), y[n_c:] * self.cell_norm.length, self.tiling
            )
            xn = self.norm.positions_in(x)
            c = self.patch.jacobian(xn)
            try:
                factor = BorderedFactor(c_k.T @ c, w_k)
            except np.linalg.LinAlgError:  # exactly on it
                return None, (y, x, xn, c, None)
            return signed_determinant(factor, sign, reference), (y, x, xn, c, factor)

        def measure(state) -> float:
            _, _, xn, c, factor = state
            return located_sigma(self.patch, xn, c, factor, self.zero_modes)

        end = evaluate(h, 0.0, None)
        if end is None or end[0] is not None and end[0] > 0:
            return None
        if end[0] is None:
            s_star, x_star = h, end[1][1]
        else:
            _, s_star, (_, x_star, _, _, _) = bracket_sign_change(evaluate, measure, h, end[0], end[1])
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
