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
boundary — the relative change of the extent between the mean positions of the opposite
boundary corner rows (motion/boundary_strain.py).  The linear (mode) value is −β; ν < 0 is auxetic.

3D chains.  Blocks (ports (±w, ±h, 0), apexes (0, 0, ±l)) moving with u = diag(1, β, γ)·x are
designed by judicious placement, then chained along x: each coupling merges the two right
ports of one block with the two left ports of the next (removes 6 degrees of freedom) and adds
one bar between their upper apexes (removes the remaining hinge), as in the main text, d = 3.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial import cKDTree

from zeromode.solver.analysis.rigidity import Analysis, analyze, zero_mode_residual
from zeromode.solver.applications.sheet_module import (
    SymmetricModule,
    sheet_edges,
    sheet_positions,
    two_node_module,
)
from zeromode.solver.applications.strain_range import (
    ModuleMotion,
    StrainRange,
    chain_range,
    module_range,
    needed_reach,
)
from zeromode.solver.construction.coupling import Module, check_transmission, couple
from zeromode.solver.construction.design import design
from zeromode.solver.construction.multimode import spatial_quadric
from zeromode.solver.construction.solution_space import solution_space
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_extent
from zeromode.solver.motion.boundary_strain import boundary_strains, poisson_ratio
from zeromode.solver.progress import progress_stage, report_progress
from zeromode.solver.tolerances import PROXIMITY_FRACTION, ROOT_IMAG_RTOL

MAX_SHEET_CELLS = 2500
# The chain's range is traced by sparse continuation; 64 blocks (≈ 2100 degrees of freedom) are
# designed, ranged and traced in a few seconds (benchmarks/bench_lattice.py).
MAX_CHAIN_BLOCKS = 64
# Strain of the expanded and contracted states when the request names none (clipped to the range).
DEFAULT_STATE_STRAIN = 0.1


@dataclass(frozen=True, eq=False)
class Lattice:
    """A designed lattice: frame, its nontrivial mode (N, d), analysis, Poisson ratio of the
    mode, finite states {name: (positions (N, d), secant Poisson ratio, strain ε_x)} inside the
    usable ``strain_range``, and the sheet's closest pair of nodes without a bar at the states,
    relative to the shortest bar (``min_node_distance``, ≥ the range's proximity fraction).
    ``driven``: the nodes that move with the affine field, the design's specified nodes (sheet:
    the corner grid; chain: the blocks' ports and apexes)."""

    frame: Frame
    mode: np.ndarray
    analysis: Analysis
    poisson_ratio: float
    states: dict
    max_relative_bar_error: float
    mode_residual: float
    boundary: dict
    strain_range: StrainRange
    min_node_distance: float
    driven: np.ndarray


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


def auxetic_sheet(
    nx: int,
    ny: int,
    poisson: float = -1.0,
    cell: tuple[float, float] = (1.0, 1.0),
    strain: float | None = None,
) -> Lattice:
    """An n_x × n_y sheet with one nontrivial zero mode of linear Poisson ratio ``poisson``.

    cell: the module's half-width w and half-height h.  The usable strain range comes from one
    module's exact symmetric curve (strain_range.module_range).  strain: ε_x of the expanded (+)
    and contracted (−) finite states, both inside the range (DomainError
    ``strain_out_of_range`` naming it otherwise); None: ±DEFAULT_STATE_STRAIN clipped to the
    range.  Each state is the module's Newton-exact configuration tiled (sheet_module).
    """
    with progress_stage(0.0, 0.3, "the module's strain range", detail=True):
        module, node_motions, motion = sheet_motion(nx, ny, poisson, tuple(cell))
    beta = -poisson
    strains = state_strains(motion.range, strain)
    positions = sheet_positions(module, nx, ny, module.reference)
    n_corners = (nx + 1) * (ny + 1)
    frame = Frame.build(positions, sheet_edges(module, nx, ny))
    affine = np.array([1.0, beta])
    centres = 0.5 * (positions[n_corners::2] + positions[n_corners + 1 :: 2])
    mode = positions * affine
    mode[n_corners::2] = centres * affine + node_motions[0]
    mode[n_corners + 1 :: 2] = centres * affine + node_motions[1]
    report_progress(0.4, "tiled the sheet")
    with progress_stage(0.4, 0.8, "analysis", detail=True):
        analysis = analyze(frame, bases=False)
    if analysis.nontrivial_zero_modes != 1:
        raise DomainError(
            "no_solution", f"the sheet has {analysis.nontrivial_zero_modes} nontrivial modes, not 1."
        )
    grid = np.arange(n_corners).reshape(ny + 1, nx + 1)
    boundary = {"left": grid[:, 0], "right": grid[:, -1], "bottom": grid[0], "top": grid[-1]}
    states = {
        name: sheet_positions(module, nx, ny, motion.at(eps)) for name, eps in strains.items()
    }
    with progress_stage(0.8, 1.0, "the states"):
        return measured_lattice(frame, mode, analysis, boundary, states, motion.range, np.arange(n_corners))


@lru_cache(maxsize=4096)
def sheet_module_for(nx: int, ny: int, poisson: float, cell: tuple[float, float]) -> tuple[SymmetricModule, np.ndarray]:
    """The module of an n_x × n_y sheet and its unspecified nodes' motions (2, 2), with every
    refusal of auxetic_sheet that needs neither the tiled sheet nor its analysis: InvalidInput
    ``invalid_size`` / ``invalid_cell``, DomainError ``no_solution`` when the module's conic
    misses its axis (module_nodes) or the reference sheet already has a collision
    (check_reference_spacing).  Cost: one module's solution space and a patch of a few modules
    (a few milliseconds), kept for the last 4096 sheets (sweep points repeat them); the arrays
    are shared: read them, never write."""
    if nx < 1 or ny < 1 or nx * ny > MAX_SHEET_CELLS:
        raise InvalidInput("invalid_size", f"cells must be between 1 and {MAX_SHEET_CELLS} in all.")
    w, h = cell
    if not (w > 0 and h > 0):
        raise InvalidInput("invalid_cell", "cell half-width and half-height must be positive.")
    # The module's motion works in the caller's units (squared bar lengths): out_of_range beyond them.
    check_extent(np.array([[w, h], [-w, -h]]), name="cell")
    _, _, nodes, node_motions = module_nodes(w, h, -poisson)
    module = two_node_module(w, h, float(nodes[0, 0]))
    check_reference_spacing(module, (nx, ny), poisson)
    return module, node_motions


def check_reference_spacing(module: SymmetricModule, cells: tuple[int, int], poisson: float) -> None:
    """DomainError ``no_solution`` when two nodes of the reference sheet that share no bar are
    closer than PROXIMITY_FRACTION of the shortest bar: the usable range's node-proximity
    condition (strain_range.py) already fails at ε = 0 (at ν = 0 a module's axis nodes coincide
    with its neighbours'), so the sheet has no usable motion and, there, more than one mode.
    Measured on the first k + 1 modules along each axis, k = needed_reach at the reference: every
    pair of the sheet that can come that close is a translate of a pair among them."""
    q0 = module.reference
    shortest = float(np.sqrt(np.min(module.squared_lengths)))
    reach = needed_reach(module, q0, shortest, cells)
    patch = (reach[0] + 1, reach[1] + 1)
    closest = closest_unjoined(sheet_positions(module, *patch, q0), sheet_edges(module, *patch)) / shortest
    if closest < PROXIMITY_FRACTION:
        raise DomainError(
            "no_solution",
            f"for Poisson ratio {poisson:g} two nodes of the sheet without a bar are {closest:.3g} of the "
            f"shortest bar apart in the reference (at least {PROXIMITY_FRACTION:g} is usable): the sheet "
            "collides at rest and has no usable motion.",
        )


@lru_cache(maxsize=1024)
def sheet_motion(
    nx: int, ny: int, poisson: float, cell: tuple[float, float]
) -> tuple[SymmetricModule, np.ndarray, ModuleMotion]:
    """sheet_module_for, and the sheet's usable range with the module's motion over it
    (strain_range.module_range: one module's scan, tens to hundreds of milliseconds), kept for
    the last 1024 sheets so that a request's precheck and its run, or sweep points that differ
    only in other options, scan once.  The arrays are shared: read them, never write."""
    module, node_motions = sheet_module_for(nx, ny, poisson, cell)
    return module, node_motions, module_range(module, (nx, ny))


def check_sheet_strain(nx: int, ny: int, poisson: float, cell: tuple[float, float], strain: float | None) -> None:
    """auxetic_sheet's ``strain_out_of_range`` (state_strains on sheet_motion's range) before
    the sheet is tiled.  None: nothing to check (the default states are clipped to the range)."""
    if strain is not None:
        state_strains(sheet_motion(nx, ny, poisson, cell)[2].range, strain)


def state_strains(usable: StrainRange, strain: float | None) -> dict[str, float]:
    """{"expanded": +ε, "contracted": −ε} for the requested ε inside ``usable``, or the default
    ±DEFAULT_STATE_STRAIN clipped to it; DomainError ``strain_out_of_range`` naming the range."""
    if strain is None:
        return {
            "expanded": min(DEFAULT_STATE_STRAIN, usable.upper.strain),
            "contracted": max(-DEFAULT_STATE_STRAIN, usable.lower.strain),
        }
    if not (usable.contains(strain) and usable.contains(-strain)):
        raise DomainError(
            "strain_out_of_range",
            f"strain ±{strain:g} is outside the usable strain range {usable.describe()}.",
        )
    return {"expanded": strain, "contracted": -strain}


def measured_lattice(frame, mode, analysis, boundary, states, usable: StrainRange, driven) -> Lattice:
    """The Lattice of a verified frame, its states measured from their positions: secant ν and
    ε_x from the boundary means, bar lengths, and the closest pair of nodes without a bar
    (progress: one report per state)."""
    lengths = np.linalg.norm(frame.positions[frame.edges[:, 0]] - frame.positions[frame.edges[:, 1]], axis=1)
    worst, closest, measured = 0.0, np.inf, {}
    for name, x in states.items():
        err = np.max(np.abs(np.linalg.norm(x[frame.edges[:, 0]] - x[frame.edges[:, 1]], axis=1) / lengths - 1))
        worst = max(worst, float(err))
        closest = min(closest, closest_unjoined(x, frame.edges) / lengths.min())
        ex, ey = boundary_strains(frame.positions, x - frame.positions, boundary)
        measured[name] = (x, -ey / ex, ex)
        report_progress(len(measured) / len(states), f"measured the {name} state")
    return Lattice(
        frame=frame,
        mode=mode,
        analysis=analysis,
        poisson_ratio=poisson_ratio(frame.positions, mode, boundary),
        states=measured,
        max_relative_bar_error=worst,
        mode_residual=zero_mode_residual(frame, mode),
        boundary={k: np.asarray(v).tolist() for k, v in boundary.items()},
        strain_range=usable,
        min_node_distance=float(closest),
        driven=np.asarray(driven, dtype=int),
    )


def closest_unjoined(x: np.ndarray, edges: np.ndarray) -> float:
    """The smallest distance between two nodes of ``x`` that share no bar: a node with D bars
    has its nearest unjoined node among its D + 1 nearest (k-d tree, O(N log N))."""
    n = len(x)
    degree = np.bincount(edges.ravel(), minlength=n)
    k = min(n, int(degree.max()) + 2)
    dist, idx = cKDTree(x).query(x, k=k)
    bars = np.sort(edges, axis=1)
    rows = np.repeat(np.arange(n), k)
    pairs = np.sort(np.column_stack([rows, idx.ravel()]), axis=1)
    # A pair (p, q), p ≤ q, as the integer p·n + q: joined when it is a bar's (or p = q).
    joined = (pairs[:, 0] == pairs[:, 1]) | np.isin(pairs[:, 0] * n + pairs[:, 1], bars[:, 0] * n + bars[:, 1])
    return float(np.min(np.where(joined.reshape(n, k), np.inf, dist)))


def _block_targets(w: float, h: float, l: float, beta: float, gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """A 3D block's specified nodes x_S (6, 3) — ports (±w, ±h, 0), apexes (0, 0, ±l) — and
    their motion diag(1, β, γ)·x_S."""
    x_s = np.array([[-w, h, 0], [-w, -h, 0], [w, h, 0], [w, -h, 0], [0, 0, l], [0, 0, -l]], dtype=float)
    return x_s, x_s * np.array([1.0, beta, gamma])


@lru_cache(maxsize=64)
def _block_3d(w: float, h: float, l: float, beta: float, gamma: float, seed: int):
    """A designed 3D block (its specified nodes first, their motion exact: _block_targets), kept
    for the last 64 blocks (a chain's precheck and its run design it once)."""
    result = design(*_block_targets(w, h, l, beta, gamma), seed=seed)
    return Module(result.frame, result.modes[0])


def chain_couplings(n: int, poisson: float, block: tuple[float, float, float]):
    """The couplings of an n-block chain (merges, bonds, as couple takes them), with every
    refusal of auxetic_chain_3d that needs no design: InvalidInput ``invalid_size``, DomainError
    ``coupling_failed`` when a block's merged ports move rigidly (coupling.check_transmission on
    the blocks' targets, which the designed blocks keep exactly; at ν = 0 the ports only translate)."""
    if not 1 <= n <= MAX_CHAIN_BLOCKS:
        raise InvalidInput("invalid_size", f"a 3D chain has between 1 and {MAX_CHAIN_BLOCKS} blocks.")
    merges = [((b - 1, 2), (b, 0)) for b in range(1, n)] + [((b - 1, 3), (b, 1)) for b in range(1, n)]
    bonds = [((b - 1, 4), (b, 4)) for b in range(1, n)]
    # Block b is block 0 translated, its motion plus a translation: whether ports move rigidly is the same.
    check_transmission([_block_targets(*block, -poisson, -poisson)] * n, merges)
    return merges, bonds


def chain_specified(n: int) -> list[tuple[int, int]]:
    """The chain's specified nodes: every block's ports and apexes, (block, node) pairs."""
    return [(b, i) for b in range(n) for i in range(6)]


def chain_modules(n: int, poisson: float, block: tuple[float, float, float], seed: int):
    """The n designed blocks of a chain, placed along x (block b moved by 2w·b, its mode by the
    affine field's translation), with their couplings (chain_couplings, whose refusals come
    first): (modules, merges, bonds)."""
    merges, bonds = chain_couplings(n, poisson, block)
    w, h, l = block
    beta = gamma = -poisson
    base = _block_3d(w, h, l, beta, gamma, seed)
    shift = np.array([2 * w, 0.0, 0.0])
    affine = np.array([1.0, beta, gamma])
    modules = [
        Module(Frame.build(base.frame.positions + b * shift, base.frame.edges), base.mode + b * shift * affine)
        for b in range(n)
    ]
    return modules, merges, bonds


def auxetic_chain_3d(
    n: int,
    poisson: float = -0.5,
    block: tuple[float, float, float] = (1.0, 1.0, 1.0),
    strain: float | None = None,
    seed: int = 0,
) -> Lattice:
    """n 3D blocks chained along x by merging two ports and adding one bar per coupling.

    Linear Poisson ratio of every block: −β for y and −γ for z, here both set to ``poisson``.
    The usable range is traced by continuation (strain_range.chain_range); the expanded and
    contracted states are the traced configurations whose ε_x is nearest ±``strain`` (as
    state_strains; their own ε_x is reported, within one continuation step of it).
    """
    with progress_stage(0.0, 0.1, "blocks"):
        modules, merges, bonds = chain_modules(n, poisson, block, seed)
    with progress_stage(0.1, 0.3, "coupling the blocks", detail=True):
        composite = couple(modules, merges, bonds, specified=chain_specified(n))
    m = composite.node_map
    boundary = {
        "left": np.array([m[0][0], m[0][1]]),
        "right": np.array([m[-1][2], m[-1][3]]),
        "bottom": np.unique([m[b][1] for b in range(n)] + [m[b][3] for b in range(n)]),
        "top": np.unique([m[b][0] for b in range(n)] + [m[b][2] for b in range(n)]),
    }
    frame, mode = composite.frame, composite.mode
    with progress_stage(0.3, 0.9, "the chain's strain range"):
        motion = chain_range(frame, mode, lambda x: boundary_strains(frame.positions, x - frame.positions, boundary)[0])
    states = {
        name: motion.positions[int(np.argmin(np.abs(motion.strains - eps)))]
        for name, eps in state_strains(motion.range, strain).items()
    }
    with progress_stage(0.9, 1.0, "the states"):
        return measured_lattice(frame, mode, composite.analysis, boundary, states, motion.range, frame.specified)
