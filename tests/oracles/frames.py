"""Frames and design targets whose answers are known by hand, and seeded random frames.

Frames are JSON-ready dicts {"dim", "positions", "edges"} (the REST contract's shape); build a
solver ``Frame`` with ``Frame.build(f["positions"], f["edges"])`` or a client ``Frame`` with
``Frame(f["positions"], f["edges"])``.
"""

from __future__ import annotations

import itertools

import numpy as np

# Paper Fig. 1d: rigid, 3 zero modes, all rigid.
TRIANGLE = {
    "dim": 2,
    "positions": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
    "edges": [[0, 1], [1, 2], [0, 2]],
}
# The unit square as a 4-cycle: one nontrivial zero mode (it shears into a rhombus).
SQUARE = {
    "dim": 2,
    "positions": [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
    "edges": [[0, 1], [1, 2], [2, 3], [3, 0]],
}
# The unit square with both diagonals: rigid with one self-stress, sides ω and diagonals −ω
# (equilibrium at a corner: two unit sides against a diagonal of length √2).
K4_SQUARE = {**SQUARE, "edges": SQUARE["edges"] + [[0, 2], [1, 3]]}
# A four-bar rectangle (sides 2 and 1) and K4 on a generic quadrilateral (one self-stress).
SQUARE_LINKAGE = {
    "dim": 2,
    "positions": [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]],
    "edges": [[0, 1], [1, 2], [2, 3], [3, 0]],
}
K4_PLANE = {
    "dim": 2,
    "positions": [[0.0, 0.0], [3.0, 0.2], [2.5, 2.0], [0.4, 1.7]],
    "edges": [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]],
}
TETRAHEDRON = {
    "dim": 3,
    "positions": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    "edges": [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]],
}
# Degenerate configurations: the rotation about the common line (3D) or point does nothing.
COLLINEAR_3D = {
    "dim": 3,
    "positions": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.5, 0.0, 0.0]],
    "edges": [[0, 1], [1, 2]],
}
SINGLE_NODE_2D = {"dim": 2, "positions": [[3.0, -1.0]], "edges": []}
# Two triangles joined at a hinge node plus a free bar: several modes and a 3D mixed case.
HINGED_3D = {
    "dim": 3,
    "positions": [
        [0.0, 0.0, 0.0],
        [1.0, 0.1, 0.0],
        [0.2, 1.0, 0.3],
        [1.1, 1.2, 0.9],
        [-0.7, 0.4, 1.3],
    ],
    "edges": [[0, 1], [1, 2], [0, 2], [2, 3], [1, 3], [3, 4]],
}
FRAMES = {
    "triangle": TRIANGLE,
    "square_linkage": SQUARE_LINKAGE,
    "k4_plane": K4_PLANE,
    "tetrahedron": TETRAHEDRON,
    "collinear_3d": COLLINEAR_3D,
    "single_node_2d": SINGLE_NODE_2D,
    "hinged_3d": HINGED_3D,
}

# Design targets. Corners of the square and the cube: with u = x they move outward, the
# paper's Fig. 3b and 3d, whose solution spaces are the circumcircle and circumsphere (Thales).
SQUARE_CORNERS = [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]
CUBE_CORNERS = [[i, j, k] for i in (-1.0, 1.0) for j in (-1.0, 1.0) for k in (-1.0, 1.0)]
# Paper Fig. 4: three (2D) and four (3D) specified nodes for two motions.
FIG4_TRIANGLE = [[-1.0, 0.0], [1.0, 0.0], [0.0, 2.0]]
FIG4_TETRAHEDRON = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]


def triangle_with_taut_sides(sides: int):
    """2D: a triangle whose first ``sides`` sides each carry a taut midpoint joint.

    ``sides`` stresses and ``sides`` flexes; each stress stiffens only its own joint, so no
    single basis stress is positive on every flex, but their sum is.
    """
    corners = np.array([[0.0, 0.0], [4.0, 0.0], [1.5, 3.0]])
    x, e = list(corners), [(0, 1), (1, 2), (0, 2)]
    for a, b in [(0, 1), (1, 2), (2, 0)][:sides]:
        x.append((corners[a] + corners[b]) / 2)
        e += [(a, len(x) - 1), (len(x) - 1, b)]
    return np.array(x), e


def arrays(frame: dict) -> tuple[np.ndarray, np.ndarray]:
    """(positions N × d, edges N_B × 2) of a JSON frame."""
    positions = np.array(frame["positions"], dtype=float).reshape(-1, frame["dim"])
    edges = np.array(frame.get("edges", []), dtype=int).reshape(-1, 2)
    return positions, edges


def random_frame(rng: np.random.Generator, dim: int, n: int, n_edges: int, lattice: bool = False):
    """Positions (n × dim) and n_edges distinct edges drawn uniformly among all pairs.

    lattice=True puts the nodes on distinct points of a small integer grid (side ≥ 4), which produces
    exact degeneracies (collinear and coplanar subsets) on purpose.
    """
    if lattice:
        side = max(4, int(np.ceil(n ** (1 / dim))) + 1)
        grid = np.array(list(itertools.product(range(side), repeat=dim)), dtype=float)
        positions = grid[rng.choice(len(grid), size=n, replace=False)]
    else:
        positions = rng.standard_normal((n, dim))
    pairs = list(itertools.combinations(range(n), 2))
    n_edges = min(n_edges, len(pairs))
    chosen = rng.choice(len(pairs), size=n_edges, replace=False) if n_edges else []
    edges = [list(pairs[k]) for k in chosen]
    for edge in edges:
        if rng.random() < 0.5:
            edge.reverse()  # orientation must not matter
    return positions, edges


def random_rotation(rng: np.random.Generator, dim: int) -> np.ndarray:
    """A uniformly random proper rotation (QR of a Gaussian matrix, sign-fixed, det +1)."""
    q, r = np.linalg.qr(rng.standard_normal((dim, dim)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q
