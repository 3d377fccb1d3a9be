"""Independent references for the client tests, computed from scratch (not via zeromode.solver)."""

from __future__ import annotations

import numpy as np

from zeromode_client import Frame

API_KEY = "test-key-3f9c"

TRIANGLE = Frame([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 2], [0, 2]])
SQUARE = Frame([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1], [1, 2], [2, 3], [3, 0]])
K4_PLANE = Frame([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2], [1, 3]])
K4_SPACE = Frame(
    [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]
)


def compatibility_matrix(positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Dense C (N_B × dN): row b = bar (i, j) holds x_i − x_j at node i and x_j − x_i at node j."""
    n, d = positions.shape
    c = np.zeros((len(edges), n * d))
    for b, (i, j) in enumerate(edges):
        c[b, d * i : d * i + d] = positions[i] - positions[j]
        c[b, d * j : d * j + d] = positions[j] - positions[i]
    return c


def rigid_motions(positions: np.ndarray) -> np.ndarray:
    """Columns spanning translations and infinitesimal rotations (dN × d(d+1)/2)."""
    n, d = positions.shape
    columns = [np.tile(np.eye(d)[a], n) for a in range(d)]
    for a in range(d):
        for b in range(a + 1, d):
            rot = np.zeros((n, d))
            rot[:, a], rot[:, b] = -positions[:, b], positions[:, a]
            columns.append(rot.ravel())
    return np.column_stack(columns)
