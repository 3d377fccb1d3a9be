"""The Maxwell frame: N point nodes in d dimensions joined by N_B rigid bars.

A frame is validated once, when it is built, so every function downstream can trust it:
finite positions of shape (N, d) with d in {2, 3}; edges of shape (N_B, 2), in range,
no self-loops, no duplicate (or reversed duplicate) edges, no bar of zero length; and
``specified`` node indices, unique and in range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.normalisation import normalised, rms_radius, unit_scaled
from zeromode.solver.errors import InvalidInput
from zeromode.solver.tolerances import COINCIDENT_RTOL


def _readonly(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


def check_positions(positions, dim: int | None = None, name: str = "positions") -> np.ndarray:
    """Return positions as a finite float array of shape (N, d), d in {2, 3}, or raise."""
    try:
        x = np.asarray(positions, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InvalidInput("invalid_shape", f"{name} must be a list of points of equal length.")
    if x.ndim != 2:
        raise InvalidInput("invalid_shape", f"{name} must be a list of points, got shape {x.shape}.")
    if dim is None:
        dim = x.shape[1]
    if dim not in (2, 3):
        raise InvalidInput("invalid_dim", f"dim must be 2 or 3, got {dim}.")
    if x.shape[1] != dim:
        raise InvalidInput(
            "invalid_shape", f"every point in {name} must have {dim} coordinates, got {x.shape[1]}."
        )
    bad = np.argwhere(~np.isfinite(x))
    if bad.size:
        i, a = bad[0]
        raise InvalidInput("not_finite", f"{name}[{i}][{a}] is not a finite number.")
    return x


# Stages that work in the caller's units (the finite motion's bar lengths and their squares)
# need squared distances to stay finite and nonzero: √(1.8e308) ≈ 1.3e154 and √(2.2e-308) ≈
# 1.5e-154, with room for sums. Frames are refused unless their extent lies between these.
UNNORMALISED_EXTENT = (1e-150, 1e150)


def check_extent(positions: np.ndarray, name: str = "positions") -> None:
    """Refuse positions (n, d) whose squared distances would overflow or underflow."""
    extent = float(np.max(np.abs(positions - positions.mean(axis=0)))) if len(positions) > 1 else 0.0
    low, high = UNNORMALISED_EXTENT
    if extent > high or 0 < extent < low:
        raise InvalidInput(
            "out_of_range",
            f"{name} span {extent:.3g}; this stage needs a frame between {low:.0e} and {high:.0e} across (rescale the input).",
        )


@dataclass(frozen=True, eq=False)
class Frame:
    """A validated bar-and-joint frame: the paper's graph G = (V, E) of N nodes at x_i in d
    dimensions and N_B bars of lengths l_ij = ‖x_i − x_j‖ (the frame of Eqs. 1–3).

    Attributes
    ----------
    positions : np.ndarray
        (N, d) float, read-only: x_i, d in {2, 3}.
    edges : np.ndarray
        (N_B, 2) int, read-only, in the order given: the bars (i, j).
    specified : tuple of int
        The indices of the specified nodes V_S (possibly empty).

    Examples
    --------
    >>> from zeromode import Frame
    >>> square = Frame.build([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1], [1, 2], [2, 3], [3, 0]])
    >>> square.maxwell_count  # N_D = dN − N_B (Eq. 2): 3 rigid motions and 1 mechanism
    4
    """

    positions: np.ndarray
    edges: np.ndarray
    specified: tuple[int, ...] = ()

    @classmethod
    def build(cls, positions, edges, specified=(), dim: int | None = None) -> Frame:
        """Validate raw input (lists or arrays) and return a Frame; raise InvalidInput naming the
        bad element (shapes, finite numbers, d in {2, 3}, edges in range, no self-loop, duplicate
        or zero-length bar, specified indices unique and in range)."""
        x = check_positions(positions, dim)
        n = len(x)
        try:
            e = np.asarray(edges if len(edges) else np.zeros((0, 2)), dtype=float)
        except (TypeError, ValueError, OverflowError):
            e = np.zeros(0)  # ragged or non-numeric: reported just below
        if e.ndim != 2 or e.shape[1] != 2:
            raise InvalidInput("invalid_edges", "edges must be a list of [i, j] pairs.")
        if not np.all(np.isfinite(e)) or not np.all(e == np.round(e)):
            k = int(np.argwhere(~np.isfinite(e) | (e != np.round(e)))[0][0])
            raise InvalidInput("invalid_edges", f"edge {k} must hold two integer node indices.")
        # Range is checked before the integer cast, which would wrap indices past 2**63.
        out = np.argwhere((e < 0) | (e >= n))
        if out.size:
            k = int(out[0][0])
            raise InvalidInput(
                "edge_out_of_range",
                f"edge {k} = {[int(v) for v in e[k]]} names a node outside 0..{n - 1}.",
            )
        e = e.astype(np.int64)
        loops = np.flatnonzero(e[:, 0] == e[:, 1])
        if loops.size:
            k = int(loops[0])
            raise InvalidInput("self_loop", f"edge {k} = {e[k].tolist()} joins a node to itself.")
        key = np.sort(e, axis=1)
        flat = key[:, 0] * n + key[:, 1]  # one integer per unordered pair (n ≤ 2**31 here)
        order = np.argsort(flat, kind="stable")
        same = np.flatnonzero(flat[order][1:] == flat[order][:-1])
        if same.size:
            k0, k1 = sorted((int(order[same[0]]), int(order[same[0] + 1])))
            raise InvalidInput(
                "duplicate_edge",
                f"edges {k0} and {k1} both join nodes {key[k0].tolist()}.",
            )
        if len(e):
            # Compared in units of max |x|, which keeps the test scale-free at any magnitude.
            y, _ = unit_scaled(x)
            lengths = np.linalg.norm(y[e[:, 0]] - y[e[:, 1]], axis=1)
            scale = max(rms_radius(y), float(np.max(np.abs(y))), np.finfo(float).tiny)
            short = np.flatnonzero(lengths <= COINCIDENT_RTOL * scale)
            if short.size:
                k = int(short[0])
                raise InvalidInput(
                    "zero_length_bar",
                    f"edge {k} = {e[k].tolist()} joins two coincident nodes.",
                )
        try:
            spec_raw = np.asarray(specified if len(specified) else [], dtype=float)
        except (TypeError, ValueError, OverflowError):
            spec_raw = np.full(1, np.nan)  # ragged or non-numeric: reported just below
        integral = np.all(np.isfinite(spec_raw)) and np.all(spec_raw == np.round(spec_raw))
        if spec_raw.ndim != 1 or not integral:
            raise InvalidInput(
                "invalid_specified", "specified must be a list of integer node indices."
            )
        spec = tuple(int(i) for i in spec_raw)
        if any(i < 0 or i >= n for i in spec):
            bad = next(i for i in spec if i < 0 or i >= n)
            raise InvalidInput("invalid_specified", f"specified node {bad} is outside 0..{n - 1}.")
        if len(set(spec)) != len(spec):
            twice = next(i for k, i in enumerate(spec) if i in spec[:k])
            raise InvalidInput("invalid_specified", f"specified lists node {twice} more than once.")
        return cls(_readonly(x.copy()), _readonly(e), spec)

    @property
    def dim(self) -> int:
        """d, the dimension (2 or 3)."""
        return int(self.positions.shape[1])

    @property
    def n_nodes(self) -> int:
        """N, the number of nodes."""
        return int(self.positions.shape[0])

    @property
    def n_edges(self) -> int:
        """N_B, the number of bars."""
        return int(self.edges.shape[0])

    @property
    def maxwell_count(self) -> int:
        """d·N − N_B (Eq. 2 of the paper)."""
        return self.dim * self.n_nodes - self.n_edges

    def normalised_positions(self) -> np.ndarray:
        """Positions centred at the centroid and divided by the RMS radius (identity scale for one point)."""
        return normalised(self.positions)
