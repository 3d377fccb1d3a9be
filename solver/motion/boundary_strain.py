"""Strain of a frame's boundary: a kinematic measure of a motion against four node sets.

A frame with boundary node sets "left", "right", "bottom", "top" (a lattice's opposite
boundary corner rows, lattice.auxetic_sheet; or sets a caller names) has, under a displacement
u (finite, or a zero mode as a rate), the strains

    ε_x = (ū_x,right − ū_x,left) / (x̄_right − x̄_left),   ε_y = (ū_y,top − ū_y,bottom) / (ȳ_top − ȳ_bottom),

the bars over the sets' means, and the Poisson ratio ν = −ε_y/ε_x (pulled along x; ν < 0 is
auxetic; a symmetric module's linear value is −β, paper, "Combining Network Modes for Potential
Applications"). Motion targets (target.py), lattices, finite strain and fabrication tolerance
all measure with these.
"""

from __future__ import annotations

import numpy as np

from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.tolerances import NO_STRETCH_RTOL


def boundary_sets(boundary: dict, n: int) -> dict[str, np.ndarray]:
    """The node sets "left", "right", "bottom", "top" of ``boundary`` as index arrays
    (InvalidInput ``invalid_boundary`` if one is missing, empty or names no node of 0..n − 1)."""
    sets = {}
    for key in ("left", "right", "bottom", "top"):
        nodes = np.asarray(boundary.get(key, []), dtype=int)
        if nodes.size == 0 or nodes.min() < 0 or nodes.max() >= n:
            raise InvalidInput("invalid_boundary", f"boundary '{key}' must list node indices in [0, {n}).")
        sets[key] = nodes
    return sets


def boundary_strains(positions: np.ndarray, motion: np.ndarray, boundary: dict) -> tuple[float, float]:
    """(ε_x, ε_y) of a displacement (finite, or a mode as a rate): the change of the extent
    x̄_right − x̄_left (resp. ȳ_top − ȳ_bottom) of the mean positions of the opposite boundary
    node sets, relative to that extent at ``positions``.  The extent is the coordinate
    difference along the axis, not the distance between the means, so the displacement must be
    free of rigid rotation (configurations aligned to the reference, as trace_motion returns)."""
    eps = []
    for lo, hi, axis in ((boundary["left"], boundary["right"], 0), (boundary["bottom"], boundary["top"], 1)):
        span = positions[hi, axis].mean() - positions[lo, axis].mean()
        eps.append((motion[hi, axis].mean() - motion[lo, axis].mean()) / span)
    return eps[0], eps[1]


def path_strains(positions: np.ndarray, path: np.ndarray, boundary: dict) -> tuple[np.ndarray, np.ndarray]:
    """Strains (P, 2) = (ε_x, ε_y) and secant Poisson ratios (P,) (−ε_y/ε_x, NaN where ε_x = 0)
    of aligned configurations ``path`` (P, N, d) relative to ``positions`` (N, d); boundary: the
    node sets "left", "right", "bottom", "top" (InvalidInput ``invalid_boundary`` if one is
    missing, empty or names no node of the frame)."""
    sets = boundary_sets(boundary, len(positions))
    strains = np.array([boundary_strains(positions, x - positions, sets) for x in path])
    with np.errstate(divide="ignore", invalid="ignore"):
        nu = np.where(strains[:, 0] != 0, -strains[:, 1] / strains[:, 0], np.nan)
    return strains, nu


def poisson_ratio(positions: np.ndarray, motion: np.ndarray, boundary: dict) -> float:
    """ν = −ε_y / ε_x of a motion (pulled along x); DomainError ``no_solution`` when ε_x vanishes
    beside ε_y (NO_STRETCH_RTOL)."""
    ex, ey = boundary_strains(positions, motion, boundary)
    if abs(ex) <= NO_STRETCH_RTOL * (abs(ey) + 1e-300):
        raise DomainError("no_solution", "the mode does not stretch the lattice along x.")
    return -ey / ex
