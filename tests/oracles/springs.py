"""The linear response of a central-force spring network, from its definition, independent of
zeromode.solver (the elastic response model of allostery and the tuning-by-pruning peer).

Bar b = (i, j) with stiffness k_b has the unit row q_b (+n_b at node i, −n_b at node j, n_b the
unit vector from j to i), K = Σ_b k_b q_b q_bᵀ. The source pair's strain is imposed by minimising
½uᵀKu under q_Sᵀu = ℓ_S (ε_S = 1) through the KKT system [[K, q_S], [q_Sᵀ, 0]], solved by dense
least squares (K is singular on the rigid motions, which strain nothing); ε_p = q_pᵀu/ℓ_p.
Stability: the singular values of diag(√k) Q (numpy's SVD). Flattening is node-major.
"""

from __future__ import annotations

import numpy as np


def unit_rows(x: np.ndarray, pairs) -> np.ndarray:
    """(P, dN) unit rows q_p of the node pairs."""
    rows = np.zeros((len(pairs), x.size))
    d = x.shape[1]
    for r, (i, j) in enumerate(pairs):
        unit = (x[i] - x[j]) / np.linalg.norm(x[i] - x[j])
        rows[r, d * i : d * i + d] = unit
        rows[r, d * j : d * j + d] = -unit
    return rows


def spring_ratio(x: np.ndarray, edges: np.ndarray, k: np.ndarray, source, target) -> float:
    """η = ε_T/ε_S of the network (stiffness k per edge) relaxed under an imposed source strain."""
    q = unit_rows(x, edges)
    q_s = unit_rows(x, [source])[0]
    kkt = np.block([[q.T @ (np.asarray(k, dtype=float)[:, None] * q), q_s[:, None]], [q_s[None, :], np.zeros((1, 1))]])
    rhs = np.zeros(x.size + 1)
    rhs[-1] = np.linalg.norm(x[source[0]] - x[source[1]])
    u = np.linalg.lstsq(kkt, rhs, rcond=None)[0][:-1].reshape(x.shape)

    def strain(pair):
        i, j = pair
        return (x[i] - x[j]) @ (u[i] - u[j]) / np.sum((x[i] - x[j]) ** 2)

    return strain(target) / strain(source)


def spring_zero_modes(x: np.ndarray, edges: np.ndarray, k: np.ndarray) -> int:
    """dim N(diag(√k) Q) by numpy's SVD, singular values below 1e-9 of the largest counting zero."""
    s = np.linalg.svd(np.sqrt(np.asarray(k, dtype=float))[:, None] * unit_rows(x, edges), compute_uv=False)
    return x.size - int(np.sum(s > 1e-9 * s[0]))
