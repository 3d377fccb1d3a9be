"""A chain of n copies of a module, the output pair of each the input pair of the next, and its
verification: the chain's conformation is the orbit of the module's map.

Chain (``chain_of``).  Copy k (k = 0…n−1) is the module at the configuration Y_k with
d_in = d_k, the iterates d_{k+1} = f(d_k) from d_0 (module_map.ModuleMap.configurations), moved
by the proper rigid motion that takes its input nodes (a, b) onto copy k−1's output nodes (c, e)
(|Y_a − Y_b| = d_k = |c − e| exactly, so that motion exists); those two nodes are shared.  Nodes:
N + (n − 1)(N − 2); bars: n·B.  A one-mode module with d_in free has one internal degree of
freedom and each shared pair ties one distance, so the chain has one nontrivial zero mode:
2(N + (n − 1)(N − 2)) − nB − 3 = n(2N − B − 3) − (n − 1) = 1 when 2N − B − 3 = 1 (planar,
no self-stress).

Verification (``verify_chain``).  The chain's finite motion (finite_motion.trace_motion) is traced
both ways until an input distance d_k (k < n) leaves the map's usable range (a fold of that copy)
or the horizon.  At every sample, with the distances d_k of its pairs read from the chain's own
configuration, d_{k+1} must equal f(d_k) evaluated from the single module (exact Newton on the
module's branch, warm-started from the module's own map, not from the chain): the conformation
is the orbit of f, d_k = f^k(d_0).  The one-step form d_{k+1} = f(d_k) is what is promised (to
MAP_RTOL): the n-fold iterate f^n(d_0) amplifies the round-off of d_0 by Π|f′(d_k)| (up to
|f′|^n at an unstable fixed point), so its deviation is reported, not promised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import MotionPath, trace_motion
from zeromode.solver.progress import progress_stage
from zeromode.solver.sequential.design import REACH, ModuleDesign, check_design, design_module
from zeromode.solver.sequential.module_map import Module, ModuleMap, branch_signs, has_branch
from zeromode.solver.tolerances import MAP_RTOL

# Most copies in a chain (a 64-module chain of the two-triangle module is 194 nodes).
MAX_MODULES = 256
# Search horizon and step of the chain's motion (finite_motion's units: RMS node displacement
# over the chain's RMS radius, so a long chain moves less per unit of parameter).
CHAIN_HORIZON = 2.0
CHAIN_MAX_STEP = 0.01
# Progress share of the module's design in a chained design, the chain's continuation taking the
# rest (measured, wall at load 8: the deployable module 3.4–4.3 s, its chain of 6 copies 2.0 s,
# of 16 copies 4.0 s).
DESIGN_SHARE = 0.5


@dataclass(frozen=True, eq=False)
class Chain:
    """n copies of ``module``; ``frame`` the chained frame; ``nodes`` (n, N) the chain's node of
    each copy's node; ``pairs`` (n + 1, 2) pair k the input pair of copy k (pair n the last
    output pair); ``iterates`` (n + 1,) the d_k it was built with."""

    frame: Frame
    module: Module
    nodes: np.ndarray
    pairs: np.ndarray
    iterates: np.ndarray

    @property
    def n_modules(self) -> int:
        return len(self.nodes)

    def distances(self, positions: np.ndarray) -> np.ndarray:
        """d_k of every pair (…, n + 1) for configurations (…, N_chain, d)."""
        p = self.pairs
        return np.linalg.norm(positions[..., p[:, 0], :] - positions[..., p[:, 1], :], axis=-1)


def _placed(y: np.ndarray, pair, onto: np.ndarray) -> np.ndarray:
    """y (N, 2) moved by the proper rigid motion taking y[pair] onto the points ``onto`` (2, 2)."""
    a, b = pair
    src, dst = y[b] - y[a], onto[1] - onto[0]
    angle = np.arctan2(dst[1], dst[0]) - np.arctan2(src[1], src[0])
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    return (y - y[a]) @ rot.T + onto[0]


def check_chain(module: Module, n: int) -> None:
    """What chain_of refuses before any work (POST /v1/jobs refuses it at submit too):
    InvalidInput for a 3D module, one with self-stress (has_branch false: its branch cannot be
    told), overlapping pairs, or n outside 1…MAX_MODULES."""
    if module.frame.dim != 2:
        raise InvalidInput("invalid_dim", "chains are built of planar modules (d = 2).")
    if not has_branch(module):
        raise InvalidInput("invalid_module", "chains are built of modules without self-stress (B = 2N − 4 bars), whose branch can be told.")
    if set(module.input_pair) & set(module.output_pair):
        raise InvalidInput("invalid_pair", "a chained module's input and output pairs must not share a node.")
    if not (isinstance(n, (int, np.integer)) and 1 <= n <= MAX_MODULES):
        raise InvalidInput("invalid_modules", f"n_modules must be an integer from 1 to {MAX_MODULES}.")


def chain_of(the_map: ModuleMap, n: int, d0: float | None = None) -> Chain:
    """The chain of n copies (module docstring) at the orbit of f from d0 (default the module's
    reference d_in).  Refusals before any work as check_chain's;
    DomainError ``chain_leaves_range`` if an iterate d_k (k < n) leaves the usable range."""
    module = the_map.module
    check_chain(module, n)
    d0 = float(module.distances(module.frame.positions)[0]) if d0 is None else float(d0)
    iterates = the_map.iterate(d0, n)
    if len(iterates) < n + 1 or not (the_map.range[0] <= iterates[n - 1] <= the_map.range[1]):
        lo, hi = the_map.range
        k = len(iterates) - 1
        raise DomainError(
            "chain_leaves_range",
            f"the orbit from d_0 = {d0:.10g} leaves the map's usable range [{lo:.6g}, {hi:.6g}] at d_{k} = "
            f"{iterates[-1]:.10g}, before the chain's {n} copies.",
        )
    return chain_at(the_map, iterates)


def chain_at(the_map: ModuleMap, distances) -> Chain:
    """The chain of n = len(distances) − 1 copies (module docstring) with copy k at d_in =
    distances[k]: an orbit of f in the usable range (d_{k+1} = f(d_k), so that copy k + 1's input
    pair fits copy k's output pair), as chain_of computes it, or the uniform state d_k = d* at a
    fixed point."""
    module = the_map.module
    iterates = np.asarray(distances, dtype=float)
    n = len(iterates) - 1
    configs = the_map.configurations(iterates[:n])
    m = module.frame.n_nodes
    (a, b), (c, e) = module.input_pair, module.output_pair
    others = [i for i in range(m) if i not in (a, b)]
    nodes = np.zeros((n, m), dtype=int)
    nodes[0] = np.arange(m)
    xy = np.zeros((m + (n - 1) * (m - 2), 2))
    xy[:m] = configs[0]
    for k in range(1, n):
        nodes[k, [a, b]] = nodes[k - 1, [c, e]]
        nodes[k, others] = m + (k - 1) * (m - 2) + np.arange(m - 2)
        xy[nodes[k, others]] = _placed(configs[k], (a, b), xy[nodes[k - 1, [c, e]]])[others]
    edges = np.concatenate([nodes[k][module.frame.edges] for k in range(n)])
    pairs = np.vstack([nodes[:, [a, b]], nodes[-1, [c, e]][None]])
    return Chain(Frame.build(xy, edges), module, nodes, pairs, iterates)


@dataclass(frozen=True, eq=False)
class ChainVerification:
    """The chain's traced motion and its comparison with the module's map.

    positions: (P, N_chain, 2) the chain's conformation at those samples (a subset of
    ``path.positions``, in the same order); reference_index: the sample that is ``chain.frame``
    (the chain as built, at the orbit from d_0);
    distances: (P, n + 1) d_k along the path (samples with every input in the map's range);
    predicted: (P, n) f(d_k) from the single module; deviation: max |d_{k+1} − f(d_k)|/d_{k+1}
    (promised ≤ MAP_RTOL); iterate_deviation: max |d_k − f^k(d_0)|/d_k over the iterates that
    stay in range (reported: it grows like Π|f′|); ends: why each direction ended."""

    chain: Chain
    path: MotionPath
    positions: np.ndarray
    reference_index: int
    distances: np.ndarray
    predicted: np.ndarray
    deviation: float
    iterate_deviation: float
    ends: tuple[str, str]


def verify_chain(chain: Chain, the_map: ModuleMap, horizon: float = CHAIN_HORIZON,
                 max_step: float = CHAIN_MAX_STEP) -> ChainVerification:
    """The chain's motion compared with the map (module docstring); DomainError
    ``chain_mismatch`` (``best`` the verification) if a step deviates by more than MAP_RTOL."""
    lo, hi = the_map.range

    def on_map(positions: np.ndarray) -> bool:
        d = chain.distances(positions)[:-1]
        signs = branch_signs(chain.module, positions[chain.nodes])
        return bool(np.all((d >= lo) & (d <= hi)) and np.all(signs == the_map.branch))

    path = trace_motion(chain.frame, amplitude=horizon, max_step=max_step, direction="both",
                        stop=lambda positions, sign: not on_map(positions))
    d = chain.distances(path.positions)
    inside = np.array([on_map(p) for p in path.positions])
    ends = tuple(
        "singular_point" if any(s.step == i for s in path.singularities)
        else "map_range" if not inside[i] else "horizon"
        for i in (0, len(d) - 1)
    )
    d = d[inside]
    reference = int(np.count_nonzero(inside[:path.reference_index]))
    predicted = the_map.evaluate(d[:, :-1])[0]
    deviation = float(np.max(np.abs(d[:, 1:] - predicted) / d[:, 1:]))
    orbit = d[:, 0].copy()
    iterate_deviation = 0.0
    for k in range(1, chain.n_modules + 1):
        live = (orbit >= lo) & (orbit <= hi)
        if not np.any(live):
            break
        orbit[live] = the_map.evaluate(orbit[live])[0]
        orbit[~live] = np.nan
        iterate_deviation = max(iterate_deviation, float(np.nanmax(np.abs(d[:, k] - orbit) / d[:, k])))
    result = ChainVerification(chain, path, path.positions[inside], reference, d, predicted, deviation, iterate_deviation, ends)
    if not deviation <= MAP_RTOL:
        error = DomainError(
            "chain_mismatch",
            f"the chain's conformation departs from the map's iterates by {deviation:.2e} (relative), more than {MAP_RTOL:g}.",
        )
        error.best = result
        raise error
    return result


@dataclass(frozen=True, eq=False)
class SequentialDesign:
    """A module designed for map points and, if asked, its chain verified by continuation."""

    design: ModuleDesign
    chain: ChainVerification | None


def check_sequential(points, start: Module | None = None, reach: float = REACH, n_modules: int | None = None) -> None:
    """What design_sequential refuses before any work: check_design's refusals and, with
    ``n_modules``, check_chain's for the start (the designed module has its bars and pairs)."""
    _, start = check_design(points, start, reach)
    if n_modules is not None:
        check_chain(start, n_modules)


def design_sequential(points, start: Module | None = None, reach: float = REACH, n_modules: int | None = None,
                      d0: float | None = None) -> SequentialDesign:
    """design.design_module for ``points``, then (``n_modules`` given) its chain from ``d0``
    (default the first point's input distance) verified by verify_chain.  Refusals as theirs,
    those before any work first (check_sequential: a chain of a 3D module is refused before the
    module is designed).  Progress: the design, then the chain's continuation."""
    check_sequential(points, start, reach, n_modules)
    if n_modules is None:
        return SequentialDesign(design_module(points, start, reach), None)
    with progress_stage(0.0, DESIGN_SHARE, "module"):
        design = design_module(points, start, reach)
    start_d = design.points[0].d_in if d0 is None else d0
    with progress_stage(DESIGN_SHARE, 1.0, "chain"):
        return SequentialDesign(design, verify_chain(chain_of(design.map, n_modules, start_d), design.map))
