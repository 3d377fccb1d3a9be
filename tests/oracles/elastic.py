"""Elastic energy of rods and springs from its definition, independent of
zeromode.solver.multistable: E(x) = Σ_s k_s (|x_i − x_j| − L_s)²/2, its gradient by hand, its
Hessian by central differences of the gradient, the rods as constraints (Lagrange multipliers
and the Lagrangian's Hessian on the constraints' tangent space), and a relaxation by scipy
with the rods as stiff springs."""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from oracles.motion import bar_lengths
from oracles.rigidity import compatibility_matrix, kernel, rigid_motions

# Central differences of an exact gradient: error O(h²·E''''), round-off O(ε·|∇E|/h).
FD_STEP = 1e-5


def energy(x, pairs, stiffness, rest) -> float:
    x = np.asarray(x, dtype=float)
    ell = bar_lengths(x, pairs)
    return float(0.5 * np.sum(np.asarray(stiffness) * (ell - np.asarray(rest)) ** 2))


def gradient(x, pairs, stiffness, rest) -> np.ndarray:
    """∂E/∂x_i = Σ k (ℓ − L) (x_i − x_j)/ℓ, (N, d)."""
    x = np.asarray(x, dtype=float)
    p = np.asarray(pairs, dtype=int).reshape(-1, 2)
    delta = x[p[:, 0]] - x[p[:, 1]]
    ell = np.linalg.norm(delta, axis=1)
    force = (np.asarray(stiffness) * (ell - np.asarray(rest)) / ell)[:, None] * delta
    g = np.zeros_like(x)
    for (i, j), f in zip(p, force):
        g[i] += f
        g[j] -= f
    return g


def hessian(x, pairs, stiffness, rest) -> np.ndarray:
    """(dN × dN) by central differences of ``gradient``, symmetrised."""
    x = np.asarray(x, dtype=float)
    n = x.size
    h = np.zeros((n, n))
    for a in range(n):
        e = np.zeros(n)
        e[a] = FD_STEP
        up = gradient((x.ravel() + e).reshape(x.shape), pairs, stiffness, rest).ravel()
        down = gradient((x.ravel() - e).reshape(x.shape), pairs, stiffness, rest).ravel()
        h[:, a] = (up - down) / (2 * FD_STEP)
    return 0.5 * (h + h.T)


def constrained_curvature(x, rods, pairs, stiffness, rest):
    """Rods as constraints g_e = |x_i − x_j| (fixed) at x (N, d) with one nontrivial flex t:
    (KKT residual ‖∇E − Jᵀλ‖/‖∇E‖, tᵀ(∇²E − Σ λ_e ∇²g_e)t / |t|²), λ by least squares, the
    Lagrangian's Hessian by central differences of ∇E − Jᵀλ (J the rods' Jacobian)."""
    x = np.asarray(x, dtype=float)
    rods = np.asarray(rods, dtype=int)

    def jacobian(y):
        c = compatibility_matrix(y, rods)  # rows (x_i − x_j) at i, −(x_i − x_j) at j
        return c / bar_lengths(y, rods)[:, None]  # ∇|x_i − x_j|

    g = gradient(x, pairs, stiffness, rest).ravel()
    lam = np.linalg.lstsq(jacobian(x).T, g, rcond=None)[0]
    kkt = np.linalg.norm(g - jacobian(x).T @ lam) / max(np.linalg.norm(g), 1e-300)
    null = kernel(compatibility_matrix(x, rods))
    rigid = rigid_motions(x)
    flex = null - rigid @ (rigid.T @ null)
    u, sv, _ = np.linalg.svd(flex, full_matrices=False)
    assert np.count_nonzero(sv > 0.5) == 1, "expected exactly one nontrivial flex"
    t = u[:, 0]

    def lagrangian_gradient(y):
        y = y.reshape(x.shape)
        return gradient(y, pairs, stiffness, rest).ravel() - jacobian(y).T @ lam

    n = x.size
    h = np.zeros((n, n))
    for a in range(n):
        e = np.zeros(n)
        e[a] = FD_STEP
        h[:, a] = (lagrangian_gradient(x.ravel() + e) - lagrangian_gradient(x.ravel() - e)) / (2 * FD_STEP)
    h = 0.5 * (h + h.T)
    return kkt, float(t @ h @ t)


def relax(x0, pairs, stiffness, rest) -> np.ndarray:
    """A local minimum of E from x0 by scipy's BFGS with the hand gradient (no Hessian): near
    it, not to round-off when rods are stiff springs (the soft mode's decrease drowns in the
    energy's round-off)."""
    x0 = np.asarray(x0, dtype=float)
    res = minimize(
        lambda v: energy(v.reshape(x0.shape), pairs, stiffness, rest),
        x0.ravel(),
        jac=lambda v: gradient(v.reshape(x0.shape), pairs, stiffness, rest).ravel(),
        method="BFGS",
        options={"gtol": 1e-10, "maxiter": 20000},
    )
    return res.x.reshape(x0.shape)


def relax_on_rods(x0, rods, lengths, pairs, stiffness, rest) -> np.ndarray:
    """A local minimum of the springs' E from x0 with the rods as exact constraints
    |x_i − x_j| = l_e, by scipy's SLSQP (hand gradients of E and of the constraints)."""
    x0 = np.asarray(x0, dtype=float)
    rods = np.asarray(rods, dtype=int)
    shape = x0.shape
    constraint = {
        "type": "eq",
        "fun": lambda v: bar_lengths(v.reshape(shape), rods) - lengths,
        "jac": lambda v: compatibility_matrix(v.reshape(shape), rods) / bar_lengths(v.reshape(shape), rods)[:, None],
    }
    res = minimize(
        lambda v: energy(v.reshape(shape), pairs, stiffness, rest),
        x0.ravel(),
        jac=lambda v: gradient(v.reshape(shape), pairs, stiffness, rest).ravel(),
        method="SLSQP",
        constraints=[constraint],
        options={"ftol": 1e-15, "maxiter": 2000},
    )
    return res.x.reshape(shape)
