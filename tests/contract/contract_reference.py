"""Independent reference math and assertions for the contract tests (/work/shared/API.md).

Nothing here imports the solver: the compatibility matrix (paper, Eq. 3), the rigid motions,
the scale normalisation, Ã = [u_Sᵀ, x_Sᵀ, −1] (Eq. 5) and the bar constraints
(x_i − x_j)·(u_i − u_j) = 0 (Eq. 1) are written out again from their definitions.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

RTOL = 1e-9
SNAKE_CASE = re.compile(r"[a-z][a-z0-9]*(_[a-z0-9]+)*")

TRIANGLE = {
    "dim": 2,
    "positions": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
    "edges": [[0, 1], [1, 2], [0, 2]],
}
# A four-bar (square, one nontrivial zero mode) and K4 in the plane (one self-stress).
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


def is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def matrix(value: Any, rows: int, cols: int) -> np.ndarray:
    """A JSON row list of exactly rows × cols finite numbers, as an array."""
    assert isinstance(value, list) and len(value) == rows, (type(value), rows)
    for row in value:
        assert isinstance(row, list) and len(row) == cols, (row, cols)
        assert all(is_number(v) for v in row), row
    return np.array(value, dtype=float).reshape(rows, cols)


def assert_error(response, code: str | None = None, status: int | None = 422) -> dict:
    """A 4xx whose body is {"detail": {"code": <snake_case>, "message": <a sentence>}}."""
    if status is None:
        assert 400 <= response.status_code < 500, (response.status_code, response.text[:300])
    else:
        assert response.status_code == status, (response.status_code, response.text[:300])
    detail = response.json()["detail"]
    assert isinstance(detail, dict), detail
    assert isinstance(detail["code"], str) and SNAKE_CASE.fullmatch(detail["code"]), detail
    assert isinstance(detail["message"], str) and len(detail["message"].split()) >= 3, detail
    if code is not None:
        assert detail["code"] == code, detail
    return detail


def normalised(positions: np.ndarray) -> np.ndarray:
    """Centred at the centroid and divided by the RMS distance to it (the scale normalisation)."""
    y = positions - positions.mean(axis=0)
    r = math.sqrt(float(np.mean(np.sum(y**2, axis=1))))
    return y / r if r > 0 else y


def compatibility(positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """C (N_B × dN), paper Eq. 3: row e = (i, j) holds x_i − x_j at node i and x_j − x_i at j."""
    n, d = positions.shape
    c = np.zeros((len(edges), n * d))
    for row, (i, j) in enumerate(np.asarray(edges, dtype=int).reshape(-1, 2)):
        c[row, d * i : d * i + d] = positions[i] - positions[j]
        c[row, d * j : d * j + d] = positions[j] - positions[i]
    return c


def rigid_motions(positions: np.ndarray) -> np.ndarray:
    """Columns spanning the rigid motions (dN × ρ): translations and u_i = Ω x_i, Ω skew."""
    n, d = positions.shape
    columns = []
    for axis in range(d):
        t = np.zeros((n, d))
        t[:, axis] = 1.0
        columns.append(t.ravel())
    for a in range(d):
        for b in range(a + 1, d):
            omega = np.zeros((d, d))
            omega[a, b], omega[b, a] = -1.0, 1.0
            columns.append((positions @ omega.T).ravel())
    basis = np.array(columns).T
    u, s, _ = np.linalg.svd(basis, full_matrices=False)
    return u[:, : int(np.sum(s > RTOL * s[0]))]


def singular_values(c: np.ndarray) -> np.ndarray:
    return np.linalg.svd(c, compute_uv=False) if c.size else np.zeros(0)


def numerical_rank(s: np.ndarray) -> int:
    return int(np.sum(s > RTOL * s[0])) if len(s) and s[0] > 0 else 0


def frame_arrays(frame: dict) -> tuple[np.ndarray, np.ndarray]:
    positions = np.array(frame["positions"], dtype=float).reshape(-1, frame["dim"])
    edges = np.array(frame.get("edges", []), dtype=int).reshape(-1, 2)
    return positions, edges


def counts(frame: dict) -> dict[str, int]:
    """The integer /v1/analyze fields, from an SVD of C of the normalised frame."""
    x, edges = frame_arrays(frame)
    n, d = x.shape
    y = normalised(x)
    rank = numerical_rank(singular_values(compatibility(y, edges)))
    rho = rigid_motions(y).shape[1]
    return {
        "nodes": n,
        "edges": len(edges),
        "dim": d,
        "maxwell_count": d * n - len(edges),
        "rank": rank,
        "zero_modes": d * n - rank,
        "rigid_body_modes": rho,
        "nontrivial_zero_modes": d * n - rank - rho,
        "self_stresses": len(edges) - rank,
    }


def a_tilde(x_s: np.ndarray, u_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ã = [u_Sᵀ, x_Sᵀ, −1] (k × (2d+1)) acting on ṽ = (x_U, u_U, c), and b_i = x_Si·u_Si."""
    k = len(x_s)
    return np.hstack([u_s, x_s, -np.ones((k, 1))]), np.sum(x_s * u_s, axis=1)


def bar_residuals(x_s, u_s, x_u, u_u) -> np.ndarray:
    """(x_Si − x_U)·(u_Si − u_U) for every i (paper, Eq. 1), relative to the factors' sizes."""
    dx, du = np.asarray(x_s) - x_u, np.asarray(u_s) - u_u
    scale = (np.linalg.norm(x_s, axis=1) + np.linalg.norm(x_u)) * (
        np.linalg.norm(u_s, axis=1) + np.linalg.norm(u_u)
    )
    return np.sum(dx * du, axis=1) / np.maximum(scale, 1e-300)


def relative_bar_errors(path: np.ndarray, edges: np.ndarray, reference: np.ndarray) -> float:
    """max over configurations and bars of | |x_i − x_j| − l | / l."""
    length = np.linalg.norm(reference[edges[:, 0]] - reference[edges[:, 1]], axis=1)
    lengths = np.linalg.norm(path[:, edges[:, 0]] - path[:, edges[:, 1]], axis=2)
    return float(np.max(np.abs(lengths - length) / length))
