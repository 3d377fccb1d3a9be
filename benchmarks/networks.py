"""Near-isostatic disordered networks for benchmarks and tests: Henneberg growth on random points.

A frame with N_B = dN − d(d+1)/2 bars and no self-stress is isostatic: rigid, and every bar
needed. Disordered networks near that point are the ones allostery and mechanism design work
with (networks pruned to ΔZ → 0, designed Maxwell frames), and the ones whose null spaces stay
small at any size, unlike lattice patches (a triangulated patch has about N self-stresses).

``henneberg_network`` grows one by Henneberg type-I steps: random points in the cube [−1, 1]^d,
numbered outward from the one nearest the centre; node i joins min(i, d) earlier nodes, so
every step adds d bars with one node and keeps the graph generically isostatic. Of its ``pool``
nearest earlier nodes it joins the d that make the best-shaped simplex with it (the largest
√det of the Gram matrix of the unit bar directions, divided by the longest bar), which keeps
the configuration far from the degenerate ones where a step would not be rigid. Then
``removed`` bars go (each opens a zero mode) and ``extra`` bars join close pairs that had none
(each closes a zero mode or adds a self-stress): generically, zero modes − self-stresses
= removed − extra, and both stay below max(removed, extra).
"""

from __future__ import annotations

from functools import partial
from itertools import combinations

import numpy as np
from scipy.spatial import cKDTree

from zeromode.solver import Frame

# Candidate neighbours per node: the nearest earlier nodes among which the d are chosen.
POOL = 8
# Nodes scored at once (their candidate simplices take POOL-choose-d · d² numbers each).
CHUNK = 4096


def henneberg_network(n: int, dim: int = 2, extra: int = 10, removed: int = 5, seed: int = 0) -> Frame:
    """A near-isostatic random network of ``n`` nodes in ``dim`` dimensions (see the module)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, dim))
    centre = np.argmin(np.linalg.norm(x, axis=1))
    x = x[np.argsort(np.linalg.norm(x - x[centre], axis=1), kind="stable")]
    tree = cKDTree(x)
    _, near = tree.query(x, k=min(n, 6 * POOL))
    node = np.arange(n)
    earlier = near < node[:, None]
    # the first POOL earlier ones of each row, nearest first; −1 pads
    first = np.argsort(~earlier, axis=1, kind="stable")[:, :POOL]
    pool = np.where(np.take_along_axis(earlier, first, axis=1), np.take_along_axis(near, first, axis=1), -1)
    simplices = np.array(list(combinations(range(POOL), dim)))
    joined = np.full((n, dim), -1)
    grow = node[np.all(pool[:, :dim] >= 0, axis=1) & (node >= dim)]
    for start in range(0, grow.size, CHUNK):
        rows = grow[start : start + CHUNK]
        choice = pool[rows][:, simplices]  # (rows, simplices, d)
        bars = x[np.maximum(choice, 0)] - x[rows][:, None, None, :]
        length = np.linalg.norm(bars, axis=-1)
        unit = bars / length[..., None]
        volume = np.sqrt(np.abs(np.linalg.det(unit @ np.swapaxes(unit, -1, -2))))
        score = np.where(np.all(choice >= 0, axis=-1), volume / length.max(axis=-1), -np.inf)
        joined[rows] = choice[np.arange(rows.size), np.argmax(score, axis=1)]
    rows = node[joined[:, 0] >= 0]
    edges = [np.column_stack([joined[rows].ravel(), np.repeat(rows, dim)])]
    for i in node[1:][joined[1:, 0] < 0]:  # the first d nodes, and any with too few listed earlier ones
        _, order = tree.query(x[i], k=n)
        edges.append(np.column_stack([order[order < i][: min(i, dim)], np.full(min(i, dim), i)]))
    edges = np.concatenate(edges)
    edges = np.delete(edges, rng.choice(len(edges), removed, replace=False), axis=0)
    reach = 1.5 * np.median(np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1))
    close = np.sort(tree.query_pairs(reach, output_type="ndarray"), axis=1)
    barred = set(map(tuple, np.sort(edges, axis=1).tolist()))
    free = close[[tuple(p) not in barred for p in close.tolist()]]
    added = free[rng.choice(len(free), extra, replace=False)]
    return Frame.build(x, np.concatenate([edges, added]), dim=dim)


NETWORKS = {
    "near-isostatic 2D": partial(henneberg_network, dim=2),
    "near-isostatic 3D": partial(henneberg_network, dim=3),
}
