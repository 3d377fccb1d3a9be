"""Auxetic lattices from symmetric modules (paper, "Combining Network Modes for Potential
Applications" and Supplementary "Combining Networks with Repeating Modules").

2D sheets.  The module is the paper's Fig. S1a: specified corners (±w, ±h) moving with the
affine field u = diag(1, β)·x, and two unspecified nodes where the module's solution conic
(paper Eq. 6, in spatial coordinates via the supplement's projection) crosses the module's
horizontal symmetry axis, (±c, 0) with c² = w² + β h².  Because the corner motion is affine,
a neighbouring copy moves consistently up to a translation, so copies tiled on a 2w × 2h grid
and merged at shared corners keep the single nontrivial mode; the redundant constraints of the
symmetric tiling appear as 2(n_x − 1)(n_y − 1) self-stresses, which do not block the motion
because every module follows the same symmetric finite motion (the supplement's argument).

That finite motion is exact and one-parameter: with corners (±a, ±b) and nodes (±c', 0), the
bars to the near and far corners keep (c' − a)² + b² = L₁² and (c' + a)² + b² = L₂², so
c' = (L₂² − L₁²)/(4a) and b = √(L₁² − (c' − a)²).  The sheet at any a is assembled from it, so
bar lengths hold to round-off at every size.

Poisson ratio (sign convention): pulled along x, ν = −ε_y / ε_x, with ε the strain of the
boundary — the relative change of the distance between the mean positions of the opposite
boundary corner rows.  The linear (mode) value is −β; ν < 0 is auxetic.

3D chains.  Blocks (ports (±w, ±h, 0), apexes (0, 0, ±l)) moving with u = diag(1, β, γ)·x are
designed by judicious placement, then chained along x: each coupling merges the two right
ports of one block with the two left ports of the next (removes 6 degrees of freedom) and adds
one bar between their upper apexes (removes the remaining hinge), as in the main text, d = 3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.coupling import Module, couple
from zeromode.solver.design import design
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.finite_motion import trace_motion
from zeromode.solver.frame import Frame
from zeromode.solver.multimode import spatial_quadric
from zeromode.solver.rigidity import Analysis, analyze, zero_mode_residual
from zeromode.solver.solution_space import solution_space
from zeromode.solver.tolerances import ROOT_IMAG_RTOL

MAX_SHEET_CELLS = 2500
# The chain's finite states come from continuation, which is dense (finite_motion.MAX_DOF).
MAX_CHAIN_BLOCKS = 16


@dataclass(frozen=True, eq=False)
class Lattice:
    """A designed lattice: frame, its nontrivial mode (N, d), analysis, Poisson ratio of the
    mode, and finite states {name: (positions (N, d), secant Poisson ratio)}."""

    frame: Frame
    mode: np.ndarray
    analysis: Analysis
    poisson_ratio: float
    states: dict
    max_relative_bar_error: float
    mode_residual: float
    boundary: dict


def module_nodes(w: float, h: float, beta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Corners (4, 2) with motion diag(1, β)·x, and the unspecified nodes (2, 2) with their
    motions, taken where the solution conic meets the symmetry axis y = 0."""
    corners = np.array([[w, h], [-w, h], [-w, -h], [w, -h]], dtype=float)
    motion = corners * np.array([1.0, beta])
    space = solution_space(corners, motion)
    quadric = spatial_quadric(space)
    if quadric is None:
        raise DomainError("no_solution", "the module's solution space is not a conic.")
    # On y = 0 (normalised coordinates keep the axis: the corners are centred), the conic is
    # q00 x² + 2 q02 x + q22 = 0.
    q = quadric.q_hat
    roots = np.roots([q[0, 0], 2 * q[0, 2], q[2, 2]])
    real = np.sort(roots[np.abs(roots.imag) <= ROOT_IMAG_RTOL * (1 + np.abs(roots.real))].real)
    if len(real) != 2 or np.isclose(real[0], real[1]):
        raise DomainError(
            "no_solution",
            f"for Poisson ratio {-beta:g} the module's solution conic does not cross its symmetry "
            "axis (need w² + β·h² > 0).",
        )
    local = np.column_stack([real[::-1], np.zeros(2)])
    nodes = space.norm.positions_out(local)
    return corners, motion, nodes, quadric.motions_at(local)


def _sheet_positions(nx: int, ny: int, a: float, b: float, c: float) -> np.ndarray:
    """Corner grid ((nx+1)(ny+1) nodes, row-major in y then x) followed by 2 nodes per module."""
    px, py = np.meshgrid((2 * np.arange(nx + 1) - nx) * a, (2 * np.arange(ny + 1) - ny) * b)
    corners = np.column_stack([px.ravel(), py.ravel()])
    cx, cy = np.meshgrid((2 * np.arange(nx) + 1 - nx) * a, (2 * np.arange(ny) + 1 - ny) * b)
    centres = np.column_stack([cx.ravel(), cy.ravel()])
    inner = np.stack([centres + [c, 0.0], centres - [c, 0.0]], axis=1).reshape(-1, 2)
    return np.vstack([corners, inner])


def _sheet_edges(nx: int, ny: int) -> np.ndarray:
    """Each unspecified node joined to the four corners of its module (8 bars per module)."""
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    i, j = i.ravel(), j.ravel()
    corner = lambda p, q: q * (nx + 1) + p
    quad = np.column_stack([corner(i + 1, j + 1), corner(i, j + 1), corner(i, j), corner(i + 1, j)])
    first = (nx + 1) * (ny + 1) + 2 * np.arange(nx * ny)
    return np.vstack(
        [np.column_stack([quad[:, m], first + s]) for s in (0, 1) for m in range(4)]
    )


def boundary_strains(positions: np.ndarray, motion: np.ndarray, boundary: dict) -> tuple[float, float]:
    """(ε_x, ε_y) of a motion: relative rate of change of the distance between the mean
    positions of the right/left and top/bottom boundary node sets."""
    eps = []
    for lo, hi, axis in ((boundary["left"], boundary["right"], 0), (boundary["bottom"], boundary["top"], 1)):
        span = positions[hi, axis].mean() - positions[lo, axis].mean()
        eps.append((motion[hi, axis].mean() - motion[lo, axis].mean()) / span)
    return eps[0], eps[1]


def poisson_ratio(positions: np.ndarray, motion: np.ndarray, boundary: dict) -> float:
    """ν = −ε_y / ε_x of a motion (pulled along x)."""
    ex, ey = boundary_strains(positions, motion, boundary)
    if abs(ex) <= 1e-14 * (abs(ey) + 1e-300):
        raise DomainError("no_solution", "the mode does not stretch the lattice along x.")
    return -ey / ex


def auxetic_sheet(
    nx: int,
    ny: int,
    poisson: float = -1.0,
    cell: tuple[float, float] = (1.0, 1.0),
    strain: float = 0.1,
) -> Lattice:
    """An n_x × n_y sheet with one nontrivial zero mode of linear Poisson ratio ``poisson``.

    cell: the module's half-width w and half-height h.  strain: the axial strain of the
    expanded (+) and contracted (−) finite states.  Each state is exact (closed form).
    """
    if nx < 1 or ny < 1 or nx * ny > MAX_SHEET_CELLS:
        raise InvalidInput("invalid_size", f"cells must be between 1 and {MAX_SHEET_CELLS} in all.")
    w, h = cell
    if not (w > 0 and h > 0):
        raise InvalidInput("invalid_cell", "cell half-width and half-height must be positive.")
    beta = -poisson
    _, _, nodes, node_motions = module_nodes(w, h, beta)
    c0 = float(nodes[0, 0])
    positions = _sheet_positions(nx, ny, w, h, c0)
    frame = Frame.build(positions, _sheet_edges(nx, ny))
    n_corners = (nx + 1) * (ny + 1)
    affine = np.array([1.0, beta])
    centres = 0.5 * (positions[n_corners::2] + positions[n_corners + 1 :: 2])
    mode = positions * affine
    mode[n_corners::2] = centres * affine + node_motions[0]
    mode[n_corners + 1 :: 2] = centres * affine + node_motions[1]
    analysis = analyze(frame, bases=False)
    if analysis.nontrivial_zero_modes != 1:
        raise DomainError(
            "no_solution", f"the sheet has {analysis.nontrivial_zero_modes} nontrivial modes, not 1."
        )
    grid = np.arange(n_corners).reshape(ny + 1, nx + 1)
    boundary = {"left": grid[:, 0], "right": grid[:, -1], "bottom": grid[0], "top": grid[-1]}
    nu = poisson_ratio(positions, mode, boundary)
    states, bar_error = _sheet_states(frame, nx, ny, w, h, c0, strain, boundary)
    return Lattice(
        frame=frame,
        mode=mode,
        analysis=analysis,
        poisson_ratio=nu,
        states=states,
        max_relative_bar_error=bar_error,
        mode_residual=zero_mode_residual(frame, mode),
        boundary={k: v.tolist() for k, v in boundary.items()},
    )


def _sheet_states(frame, nx, ny, w, h, c0, strain, boundary):
    """Expanded and contracted configurations from the module's exact one-parameter motion."""
    l1 = (c0 - w) ** 2 + h**2
    l2 = (c0 + w) ** 2 + h**2
    lengths = np.linalg.norm(frame.positions[frame.edges[:, 0]] - frame.positions[frame.edges[:, 1]], axis=1)
    states, worst = {}, 0.0
    for name, a in (("expanded", w * (1 + strain)), ("contracted", w * (1 - strain))):
        c = (l2 - l1) / (4 * a)
        b2 = l1 - (c - a) ** 2
        if a <= 0 or b2 <= 0:
            raise DomainError(
                "no_solution", f"the module locks before reaching the {name} state at strain {strain:g}."
            )
        x = _sheet_positions(nx, ny, a, np.sqrt(b2), c)
        err = np.max(np.abs(np.linalg.norm(x[frame.edges[:, 0]] - x[frame.edges[:, 1]], axis=1) / lengths - 1))
        worst = max(worst, float(err))
        ex, ey = boundary_strains(frame.positions, x - frame.positions, boundary)
        states[name] = (x, -ey / ex)
    return states, worst


def _block_3d(w: float, h: float, l: float, beta: float, gamma: float, seed: int):
    """A designed 3D block: ports (±w, ±h, 0), apexes (0, 0, ±l), motion diag(1, β, γ)·x."""
    x_s = np.array([[-w, h, 0], [-w, -h, 0], [w, h, 0], [w, -h, 0], [0, 0, l], [0, 0, -l]], dtype=float)
    u_s = x_s * np.array([1.0, beta, gamma])
    result = design(x_s, u_s, seed=seed)
    return Module(result.frame, result.modes[0])


def auxetic_chain_3d(
    n: int,
    poisson: float = -0.5,
    block: tuple[float, float, float] = (1.0, 1.0, 1.0),
    strain: float = 0.1,
    seed: int = 0,
) -> Lattice:
    """n 3D blocks chained along x by merging two ports and adding one bar per coupling.

    Linear Poisson ratio of every block: −β for y and −γ for z, here both set to ``poisson``.
    The expanded and contracted states are the ends of the traced finite motion (continuation,
    ``finite_motion.trace_motion``) to a parameter of ``strain`` either way.
    """
    if not 1 <= n <= MAX_CHAIN_BLOCKS:
        raise InvalidInput("invalid_size", f"a 3D chain has between 1 and {MAX_CHAIN_BLOCKS} blocks.")
    w, h, l = block
    beta = gamma = -poisson
    base = _block_3d(w, h, l, beta, gamma, seed)
    shift = np.array([2 * w, 0.0, 0.0])
    affine = np.array([1.0, beta, gamma])
    modules = [
        Module(Frame.build(base.frame.positions + b * shift, base.frame.edges), base.mode + b * shift * affine)
        for b in range(n)
    ]
    merges = [((b - 1, 2), (b, 0)) for b in range(1, n)] + [((b - 1, 3), (b, 1)) for b in range(1, n)]
    bonds = [((b - 1, 4), (b, 4)) for b in range(1, n)]
    composite = couple(modules, merges, bonds, specified=[(b, i) for b in range(n) for i in range(6)])
    m = composite.node_map
    boundary = {
        "left": np.array([m[0][0], m[0][1]]),
        "right": np.array([m[-1][2], m[-1][3]]),
        "bottom": np.unique([m[b][1] for b in range(n)] + [m[b][3] for b in range(n)]),
        "top": np.unique([m[b][0] for b in range(n)] + [m[b][2] for b in range(n)]),
    }
    frame, mode = composite.frame, composite.mode
    path = trace_motion(frame, mode, amplitude=strain, direction="both")
    states = {}
    for end in (path.positions[0], path.positions[-1]):
        ex, ey = boundary_strains(frame.positions, end - frame.positions, boundary)
        states["expanded" if ex > 0 else "contracted"] = (end, -ey / ex)
    return Lattice(
        frame=frame,
        mode=mode,
        analysis=composite.analysis,
        poisson_ratio=poisson_ratio(frame.positions, mode, boundary),
        states=states,
        max_relative_bar_error=path.max_relative_bar_error,
        mode_residual=zero_mode_residual(frame, mode),
        boundary={k: v.tolist() for k, v in boundary.items()},
    )
