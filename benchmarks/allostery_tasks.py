"""Seeded allosteric design tasks: a random rigid 2D spring network, a source and a target pair.

A task asks for η = ε_T/ε_S, the strain of the target pair per unit strain of the source pair
(pair strain ε_p = (x_i − x_j)·(u_i − u_j)/|x_i − x_j|², linear response). The same task reads
as a prescribed motion of the four specified nodes (``specified_motion``), the form the
analytic designer takes: the source pair pulled apart along its axis by ε_S, the target pair
by η ε_S.

Networks are "jammed-like": N soft disks relaxed inside a circular wall at packing fraction
0.9 (above 2D jamming), Delaunay-triangulated, then diluted homogeneously — long wall bars
first, then always a bar between the best-connected nodes — keeping only removals that open no
zero mode, down to an excess coordination ΔZ = Z − Z_iso above the isostatic count
N_B = dN − d(d+1)/2. Positions are normalised (centroid 0, RMS radius 1).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial import Delaunay, cKDTree

from zeromode.solver import Frame
from zeromode.solver.analysis.bond_green import SpringNetwork

DIM = 2
PACKING_FRACTION = 0.9
RELAX_STEPS = 300
# Bars longer than this many median lengths are slivers along the wall; they go first.
LONG_BAR = 1.5
DEFAULT_EXCESS_COORDINATION = 0.5


@dataclass(frozen=True, eq=False)
class AllosteryTask:
    """One design task. frame.specified = (*source_pair, *target_pair)."""

    frame: Frame
    source_pair: tuple[int, int]
    target_pair: tuple[int, int]
    ratio: float
    tol: float
    seed: int
    excess_coordination: float

    @property
    def n_nodes(self) -> int:
        return self.frame.n_nodes

    def pair_motion(self, pair: tuple[int, int], strain: float) -> np.ndarray:
        """(2, d) motion of ``pair`` = (i, j): ±½ strain·(x_i − x_j), so ε_pair = strain."""
        x = self.frame.positions
        half = 0.5 * strain * (x[pair[0]] - x[pair[1]])
        return np.stack([half, -half])

    def specified_motion(self, source_strain: float = 1.0) -> np.ndarray:
        """(4, d) prescribed motion of frame.specified: source strain ε_S, target strain η ε_S."""
        return np.concatenate(
            [
                self.pair_motion(self.source_pair, source_strain),
                self.pair_motion(self.target_pair, self.ratio * source_strain),
            ]
        )


def relaxed_disks(n: int, rng: np.random.Generator) -> np.ndarray:
    """(N, 2) centres of N soft disks of diameter σ relaxed in the unit circle.

    Gradient descent on the harmonic overlap energy Σ (σ − r_ij)² (plus the wall), from uniform
    random centres; σ fixes the packing fraction N π σ²/4 = PACKING_FRACTION · π.
    """
    sigma = 2.0 * np.sqrt(PACKING_FRACTION / n)
    r = np.sqrt(rng.uniform(0, 1, n))
    theta = rng.uniform(0, 2 * np.pi, n)
    x = np.column_stack([r * np.cos(theta), r * np.sin(theta)])
    for _ in range(RELAX_STEPS):
        pairs = cKDTree(x).query_pairs(sigma, output_type="ndarray")
        step = np.zeros_like(x)
        if len(pairs):
            d = x[pairs[:, 0]] - x[pairs[:, 1]]
            dist = np.linalg.norm(d, axis=1, keepdims=True)
            push = 0.25 * (sigma - dist) * d / np.maximum(dist, 1e-12)
            np.add.at(step, pairs[:, 0], push)
            np.add.at(step, pairs[:, 1], -push)
        radius = np.linalg.norm(x, axis=1, keepdims=True)
        outside = np.maximum(radius + 0.5 * sigma - 1.0, 0.0)
        step -= 0.5 * outside * x / np.maximum(radius, 1e-12)
        x = x + step
    return x


@lru_cache(maxsize=64)
def random_network(
    n: int, seed: int, excess_coordination: float = DEFAULT_EXCESS_COORDINATION
) -> Frame:
    """A rigid jammed-like 2D network of ``n`` nodes with Z − Z_iso ≈ ``excess_coordination``.

    Z = 2 N_B / N and Z_iso = 2(dN − 3)/N, so the dilution stops at
    N_B = dN − 3 + round(ΔZ · N / 2) bars, or earlier if no bar can go without opening a zero
    mode (D_b ≤ FLOPPY_RTOL, unit stiffnesses; see solver.analysis.bond_green). Each removal takes a
    long wall bar if any is left, else a bar joining the two best-connected nodes (largest
    z_i + z_j, seeded ties): this keeps Z uniform, so states of self-stress stay extended as
    in a jammed packing rather than pooling in over-braced clusters.
    """
    rng = np.random.default_rng(seed)
    x = relaxed_disks(n, rng)
    x = x / np.sqrt(np.mean(np.sum((x - x.mean(axis=0)) ** 2, axis=1)))
    simplices = Delaunay(x).simplices
    tri_edges = np.concatenate([simplices[:, [0, 1]], simplices[:, [1, 2]], simplices[:, [0, 2]]])
    edges = np.unique(np.sort(tri_edges, axis=1), axis=0)
    lengths = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)
    long_bar = lengths > LONG_BAR * np.median(lengths)
    target = DIM * n - 3 + round(excess_coordination * n / 2)
    tie = rng.permutation(len(edges))

    net = SpringNetwork(x, edges, np.ones(len(edges)))
    while net.alive.sum() > target:
        candidates = net.removable()
        if candidates.size == 0:
            break
        degree = np.bincount(edges[net.alive].ravel(), minlength=n)
        priority = np.lexsort(
            (tie[candidates], -degree[edges[candidates]].sum(axis=1), ~long_bar[candidates])
        )
        net.remove(int(candidates[priority[0]]))
    return Frame.build(x, edges[net.alive])


def unbonded_pairs(frame: Frame) -> np.ndarray:
    """(P, 2) node pairs closer than two median bar lengths that no bar joins."""
    x, e = frame.positions, frame.edges
    reach = 2.0 * np.median(np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1))
    close = cKDTree(x).query_pairs(reach, output_type="ndarray")
    close = np.sort(close, axis=1)
    bars = set(map(tuple, np.sort(e, axis=1).tolist()))
    return close[[tuple(p) not in bars for p in close.tolist()]]


def make_task(
    n: int,
    seed: int,
    ratio: float,
    tol: float | None = None,
    excess_coordination: float = DEFAULT_EXCESS_COORDINATION,
) -> AllosteryTask:
    """A seeded task on ``random_network(n, seed, ΔZ)``.

    Source: a random nearby pair of nodes that no bar joins (``unbonded_pairs``). Target: a
    random such pair whose midpoint is at least 3/4 of the largest midpoint distance from the
    source's. Unbonded, because a bar on the source or target pair lets the greedy unload it —
    e.g. by pruning a target node down to two bars, which forces ε_T = 0 exactly — a dead end
    it then cannot leave. tol defaults to 1 % of max(|ratio|, 1) (Rocks et al.'s 1 %).
    """
    net = random_network(n, seed, excess_coordination)
    rng = np.random.default_rng([seed, 1])
    pairs = unbonded_pairs(net)
    mid = net.positions[pairs].mean(axis=1)
    source = pairs[rng.integers(len(pairs))]
    dist = np.linalg.norm(mid - net.positions[source].mean(axis=0), axis=1)
    target = pairs[rng.choice(np.flatnonzero(dist >= 0.75 * dist.max()))]
    s1, s2, t1, t2 = (int(i) for i in (*source, *target))
    frame = Frame.build(net.positions, net.edges, specified=(s1, s2, t1, t2))
    return AllosteryTask(
        frame=frame,
        source_pair=(s1, s2),
        target_pair=(t1, t2),
        ratio=float(ratio),
        tol=float(0.01 * max(abs(ratio), 1.0) if tol is None else tol),
        seed=seed,
        excess_coordination=excess_coordination,
    )
