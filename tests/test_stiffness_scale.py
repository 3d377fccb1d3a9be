"""The optimal-stiffness margin at scale (zeromode.solver.certificates.stiffness) against independent routes.

Oracles: stiffness matrices, complements and eigenvalues built from scratch with numpy
(tests/oracles/rigidity.py), the SDP route (cvxpy + Clarabel) where both run, random
allocations (none may beat a verified upper bound), and the frame's symmetry checked on the
positions themselves.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from oracles.rigidity import compatibility_matrix, kernel, normalised, rigid_generators, span

from zeromode.solver import Frame
from zeromode.solver.applications.lattice import auxetic_sheet
from zeromode.solver.certificates.prestress import (
    SDP_MAX_DIM,
    certify,
    solve_lmi,
    stiffness_program,
)
from zeromode.solver.certificates.stiffness import (
    GAP_RTOL,
    optimal_stiffness,
    reduce_lmi,
    sign_symmetries,
    spectral_bundle,
)


def problem(frame: Frame, modes):
    """(normalised positions, dense C, orthonormal span of rigid motions ⊕ modes, complement P),
    all from scratch."""
    x = normalised(frame.positions)
    c = compatibility_matrix(x, frame.edges)
    fixed = span(np.column_stack([rigid_generators(x)] + [np.ravel(m) for m in modes]))
    return x, c, fixed, kernel(fixed.T)


def margin(c, p, k) -> float:
    """λ_min(Pᵀ Cᵀ diag(k) C P) with numpy."""
    return float(np.linalg.eigvalsh(p.T @ c.T @ np.diag(k) @ c @ p)[0])


def sheet(n: int):
    lattice = auxetic_sheet(n, n, poisson=-0.5)
    return lattice.frame, [lattice.mode]


def triangulated_strip(n: int) -> Frame:
    """A rigid strip of n nodes with no reflection symmetry (the bottom row bends)."""
    x = [[i // 2, i % 2 + 0.1 * (i // 2) ** 1.5 / n] for i in range(n)]
    e = [[i, i + 1] for i in range(n - 1)] + [[i, i + 2] for i in range(n - 2)]
    return Frame.build(x, e)


def check_bracket(result, c, fixed, p):
    """The result's bracket recomputed outside the solver: the lower bound is attained by its
    allocation, the upper bound is N_B·max_e c_eᵀYc_e for its dual Y, a unit-trace PSD matrix
    on the complement, and no allocation — uniform or random — beats it."""
    n_bars = c.shape[0]
    k = result.stiffness
    assert np.all(k >= 0) and k.sum() == pytest.approx(n_bars)
    attained = margin(c, p, k)
    assert result.lower <= attained * (1 + 1e-9)
    assert result.lower == pytest.approx(attained, rel=1e-6)
    v = result.dual
    assert np.linalg.norm(fixed.T @ v) <= 1e-9 * np.linalg.norm(v)  # Y = VVᵀ/‖V‖² ⟂ span
    y = v @ v.T / np.sum(v**2)
    assert np.trace(y) == pytest.approx(1.0) and np.linalg.eigvalsh(y)[0] >= -1e-12
    assert result.upper == pytest.approx(n_bars * float(np.max(np.einsum("ei,ij,ej->e", c, y, c))), rel=1e-9)
    assert margin(c, p, np.ones(n_bars)) <= result.upper
    for trial in np.random.default_rng(3).dirichlet(np.ones(n_bars), size=50) * n_bars:
        assert margin(c, p, trial) <= result.upper * (1 + 1e-9)
    assert result.lower <= result.upper


def test_the_sheet_has_its_two_reflections_and_the_reduction_block_diagonalises_every_orbit_allocation():
    frame, modes = sheet(3)
    x, c, fixed, p = problem(frame, modes)
    axes, signs, perms = sign_symmetries(x, frame.edges, fixed)
    assert {tuple(s) for s in signs} == {(1, 1), (-1, 1), (1, -1), (-1, -1)}
    assert np.allclose(np.abs(axes).max(axis=0), 1.0, atol=1e-12)  # the sheet's axes: x and y
    centred = x - x.mean(axis=0)
    for s, perm in zip(signs, perms):  # checked on the positions: each reflection permutes the nodes
        assert np.allclose(centred[perm], centred @ ((axes * s) @ axes.T).T, atol=1e-12)
    reduction = reduce_lmi(x, frame.edges, fixed)
    q = np.column_stack(reduction.bases)
    assert q.shape == p.shape and np.allclose(q.T @ q, np.eye(p.shape[1]), atol=1e-10)
    assert np.linalg.norm(fixed.T @ q) <= 1e-10
    # An allocation constant on bar orbits: the blocks carry the whole spectrum of PᵀKP and
    # nothing couples two blocks.
    rng = np.random.default_rng(0)
    k = rng.uniform(0.5, 2.0, reduction.sizes.size)[reduction.orbit]
    stiffness = c.T @ np.diag(k) @ c
    reduced = q.T @ stiffness @ q
    sizes = np.cumsum([0] + [b.shape[1] for b in reduction.bases])
    for i in range(len(reduction.bases)):
        for j in range(len(reduction.bases)):
            if i != j:
                assert np.abs(reduced[sizes[i] : sizes[i + 1], sizes[j] : sizes[j + 1]]).max() <= 1e-10 * np.abs(reduced).max()
    assert np.allclose(np.linalg.eigvalsh(reduced), np.linalg.eigvalsh(p.T @ stiffness @ p), atol=1e-10)
    # Orbits are unions of bars whose images under the flips coincide.
    for e, (i, j) in enumerate(frame.edges):
        for perm in perms:
            image = {perm[i], perm[j]}
            partner = [b for b, (a, z) in enumerate(frame.edges) if {a, z} == image]
            assert reduction.orbit[partner[0]] == reduction.orbit[e]


def test_a_designed_mode_that_breaks_a_reflection_removes_it_from_the_group():
    frame, _ = sheet(2)
    x, _, fixed, _ = problem(frame, [])
    # A motion that x ↦ −x maps to itself but y ↦ −y does not (odd in y for the first nodes).
    lopsided = np.zeros_like(x)
    lopsided[:, 1] = x[:, 1] + 0.3 * x[:, 1] ** 2
    extended = span(np.column_stack([fixed, lopsided.ravel()]))
    axes, signs, _ = sign_symmetries(x, frame.edges, extended)
    kept = {tuple(np.round((axes * s) @ axes.T, 12).ravel()) for s in signs}
    assert kept == {(1, 0, 0, 1), (-1, 0, 0, 1)}


@pytest.mark.parametrize("n", [2, 3])
def test_sheets_agree_with_the_sdp_route_and_with_no_reduction(n):
    """Small sheets (p ≤ SDP_MAX_DIM for 2 × 2; 3 × 3 by the unreduced method): the reduced
    route's verified bracket contains the SDP's optimum and the unreduced route's."""
    frame, modes = sheet(n)
    x, c, fixed, p = problem(frame, modes)
    uniform = margin(c, p, np.ones(len(c)))
    reduced = optimal_stiffness(sp.csr_matrix(c), fixed, uniform, x, frame.edges)
    assert reduced.group_order == 4 and reduced.status == "optimal"
    assert sum(reduced.blocks) == p.shape[1] and max(reduced.blocks) < p.shape[1]
    check_bracket(reduced, c, fixed, p)
    assert reduced.upper - reduced.lower <= GAP_RTOL * reduced.upper
    plain = optimal_stiffness(sp.csr_matrix(c), fixed, uniform)
    assert plain.group_order == 1 and plain.blocks == (p.shape[1],)
    check_bracket(plain, c, fixed, p)
    assert plain.lower <= reduced.upper * (1 + 1e-9) and reduced.lower <= plain.upper * (1 + 1e-9)
    if p.shape[1] <= SDP_MAX_DIM:
        sdp = solve_lmi(stiffness_program(c @ p))
        assert sdp.lower <= reduced.upper * (1 + 1e-9) and reduced.lower <= sdp.upper * (1 + 1e-9)
        assert reduced.lower == pytest.approx(sdp.lower, rel=GAP_RTOL)


def test_an_asymmetric_frame_runs_unreduced_and_agrees_with_the_sdp():
    frame = triangulated_strip(20)  # p = 37
    x, c, fixed, p = problem(frame, [])
    uniform = margin(c, p, np.ones(len(c)))
    result = optimal_stiffness(sp.csr_matrix(c), fixed, uniform, x, frame.edges)
    assert result.group_order == 1 and result.status == "optimal"
    check_bracket(result, c, fixed, p)
    sdp = solve_lmi(stiffness_program(c @ p))
    assert sdp.lower <= result.upper * (1 + 1e-9) and result.lower <= sdp.upper * (1 + 1e-9)


def test_certify_takes_a_sheet_beyond_the_sdp_size_to_the_interior_point_route():
    frame, modes = sheet(4)  # p = 110
    got = certify(frame, modes).rigidity_margin
    assert got.complement_dim > SDP_MAX_DIM
    assert got.sdp.solver == "interior_point" and got.sdp.status == "optimal"
    _, c, _, p = problem(frame, modes)
    assert got.uniform == pytest.approx(margin(c, p, np.ones(len(c))), rel=1e-8)
    assert got.optimal == pytest.approx(margin(c, p, got.stiffness), rel=1e-6)
    assert got.uniform <= got.optimal <= got.optimal_upper_bound
    assert got.optimal_upper_bound - got.optimal <= GAP_RTOL * got.optimal_upper_bound
    for trial in np.random.default_rng(5).dirichlet(np.ones(len(c)), size=50) * len(c):
        assert margin(c, p, trial) <= got.optimal_upper_bound


def test_the_spectral_bundle_route_brackets_the_sdp_optimum():
    """The route for frames whose reduced blocks stay large, on a small one where the SDP runs."""
    frame = triangulated_strip(16)  # p = 29
    _, c, fixed, p = problem(frame, [])
    uniform = margin(c, p, np.ones(len(c)))
    result = spectral_bundle(sp.csr_matrix(c), fixed, uniform)
    assert result.method == "spectral_bundle" and result.status == "optimal"
    assert result.upper - result.lower <= GAP_RTOL * result.upper
    assert result.lower <= margin(c, p, result.stiffness) * (1 + 1e-9)
    sdp = solve_lmi(stiffness_program(c @ p))
    assert sdp.lower <= result.upper * (1 + 1e-9) and result.lower <= sdp.upper * (1 + 1e-9)


def test_a_spent_time_limit_still_returns_a_verified_bracket():
    """Stopped before its first Newton step (time_s = 0), the route verifies its starting point:
    the uniform allocation's margin below, its starting dual above, and says the gap is open."""
    frame, modes = sheet(3)
    x, c, fixed, p = problem(frame, modes)
    uniform = margin(c, p, np.ones(len(c)))
    result = optimal_stiffness(sp.csr_matrix(c), fixed, uniform, x, frame.edges, time_s=0.0)
    assert result.method == "interior_point" and result.status == "gap_not_closed"
    assert result.iterations == 0 and result.upper - result.lower > GAP_RTOL * result.upper
    check_bracket(result, c, fixed, p)
    assert result.lower == pytest.approx(uniform, rel=1e-6)


def test_a_rotated_sheet_is_reduced_along_its_own_axes_to_the_same_optimum():
    frame, modes = sheet(3)
    angle = 0.4
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    turned = Frame.build(frame.positions @ rotation.T, frame.edges)
    results = []
    for f, m in ((frame, modes), (turned, [modes[0] @ rotation.T])):
        x, c, fixed, p = problem(f, m)
        uniform = margin(c, p, np.ones(len(c)))
        result = optimal_stiffness(sp.csr_matrix(c), fixed, uniform, x, f.edges)
        assert result.group_order == 4 and result.status == "optimal"
        check_bracket(result, c, fixed, p)
        results.append(result)
    assert results[1].lower <= results[0].upper * (1 + 1e-9) and results[0].lower <= results[1].upper * (1 + 1e-9)


def mirrored_frame(seed: int, dim: int = 2, per_orthant: int = 5) -> Frame:
    """Random points in the open orthant x > 0 and their mirror images in every axis, with the
    Delaunay edges of all of them and every mirror image of each edge: a frame that the
    reflections in the coordinate planes map onto itself, by construction."""
    from itertools import product

    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    orthant = rng.uniform(0.1, 1.0, (per_orthant, dim))
    signs = np.array(list(product([1, -1], repeat=dim)))
    x = np.concatenate([orthant * s for s in signs])  # node j of copy c: index per_orthant·c + j
    copy = {tuple(s): c for c, s in enumerate(signs.tolist())}
    edges = set()
    for simplex in Delaunay(x).simplices:
        for i, j in ((int(a), int(b)) for a in simplex for b in simplex if a < b):
            for t in signs:
                u, v = (per_orthant * copy[tuple(signs[k // per_orthant] * t)] + k % per_orthant for k in (i, j))
                edges.add((min(u, v), max(u, v)))
    return Frame.build(x, sorted(edges))


@pytest.mark.parametrize(("seed", "dim", "per_orthant"), [(1, 2, 5), (2, 2, 5), (3, 2, 5), (4, 3, 2), (5, 3, 2)])
def test_random_mirrored_frames_agree_with_the_sdp(seed, dim, per_orthant):
    frame = mirrored_frame(seed, dim, per_orthant)  # 20 nodes in 2D (p = 37), 16 in 3D (p = 42)
    x, c, fixed, p = problem(frame, [])
    uniform = margin(c, p, np.ones(len(c)))
    result = optimal_stiffness(sp.csr_matrix(c), fixed, uniform, x, frame.edges)
    assert result.group_order == 2**dim and len(result.blocks) == 2**dim and result.status == "optimal"
    check_bracket(result, c, fixed, p)
    sdp = solve_lmi(stiffness_program(c @ p))
    assert sdp.lower <= result.upper * (1 + 1e-9) and result.lower <= sdp.upper * (1 + 1e-9)
    assert result.lower == pytest.approx(sdp.lower, rel=GAP_RTOL)
