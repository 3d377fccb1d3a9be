"""Branched multistable designs (zm.multistable with ``bifurcation``), checked from the body by
the test's own mathematics: the compatibility matrix written here from its definition loses
one rank at the branch conformation (numpy SVD), both reported tangents are zero modes that
satisfy the second-order condition Σ_e ω_e |u_i − u_j|² = 0 for the self-stress ω found here,
a continuation written here (scipy.optimize.least_squares on the bar lengths, pseudo-arclength
steps from the point displaced along each tangent) keeps every rod's length on both branches,
which are different curves, and the stated branch reaches the next conformation."""

import numpy as np
import pytest
from oracles.elastic import constrained_curvature
from oracles.motion import bar_lengths, rigid_distance
from scipy.optimize import least_squares, minimize_scalar

import zeromode as zm
from zeromode.solver.errors import DomainError

APEX = [[0.3, 0.8], [0.45, 1.0], [0.65, 1.15]]
CONFORMATIONS = [[[0.0, 0.0], [1.0, 0.0], p] for p in APEX]
BRANCH = 1


def compatibility(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """C of Eq. 1 from the definition: row e = (i, j) holds x_i − x_j at node i, x_j − x_i at j."""
    n, d = x.shape
    c = np.zeros((len(edges), n * d))
    for e, (i, j) in enumerate(edges):
        c[e, d * i : d * i + d] = x[i] - x[j]
        c[e, d * j : d * j + d] = x[j] - x[i]
    return c


def rigid(x: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the 2D rigid motions at x: two translations and the rotation J x."""
    n = len(x)
    g = np.zeros((2 * n, 3))
    g[0::2, 0] = 1
    g[1::2, 1] = 1
    g[0::2, 2], g[1::2, 2] = -x[:, 1], x[:, 0]
    return np.linalg.qr(g)[0]


def normalised(x: np.ndarray) -> np.ndarray:
    y = x - x.mean(axis=0)
    return y / np.sqrt(np.mean(np.sum(y * y, axis=1)))


def second_order(omega: np.ndarray, u: np.ndarray, edges: np.ndarray) -> float:
    """Σ_e ω_e |u_i − u_j|² for u (N, 2)."""
    du = u[edges[:, 0]] - u[edges[:, 1]]
    return float(np.sum(omega * np.sum(du * du, axis=1)))


def branch_steps(x: np.ndarray, edges: np.ndarray, tangent: np.ndarray, h: float, steps: int):
    """Configurations (steps + 1, N, 2) along the branch leaving x with ``tangent`` (unit in
    R^{2N}): each step the point displaced by h along the current direction (the tangent, then
    the secant of the last two points) solved back onto the bar lengths by least squares,
    with the displacement along the direction fixed to h and no rigid motion of the last point."""
    lengths2 = bar_lengths(x, edges) ** 2
    points, direction = [x.ravel()], tangent.ravel() / np.linalg.norm(tangent)
    for _ in range(steps):
        y_k = points[-1]
        gauge = rigid(y_k.reshape(x.shape)).T

        def residual(y, y_k=y_k, gauge=gauge, direction=direction):
            bars = bar_lengths(y.reshape(x.shape), edges) ** 2 - lengths2
            return np.concatenate([bars, gauge @ (y - y_k), [direction @ (y - y_k) - h]])

        got = least_squares(residual, y_k + h * direction, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        points.append(got.x)
        direction = (got.x - y_k) / np.linalg.norm(got.x - y_k)
    return np.stack(points).reshape(-1, *x.shape)


@pytest.fixture(scope="module")
def body():
    return zm.multistable(CONFORMATIONS, bifurcation=BRANCH).to_dict()


@pytest.fixture(scope="module")
def at_branch(body):
    """(normalised positions at the branch conformation, edges, the reported bifurcation)."""
    edges = np.asarray(body["frame"]["edges"])
    x = normalised(np.asarray(body["conformations"][BRANCH], dtype=float))
    return x, edges, body["bifurcation"]


def test_compatibility_matrix_loses_one_rank_at_the_branch_point(body, at_branch):
    x, edges, b = at_branch
    s = np.linalg.svd(compatibility(x, edges), compute_uv=False)
    s = s / s[0]
    assert len(s) == len(edges)
    assert s[-1] <= 1e-12 and s[-2] >= 1e-3  # one self-stress: rank N_B − 1
    assert b["rank"] == len(edges) - 1
    assert b["sigma_dropped"] == pytest.approx(s[-1], abs=1e-12) and b["sigma_kept"] == pytest.approx(s[-2], rel=1e-6)
    zero_modes = 2 * len(x) - (len(edges) - 1)
    assert zero_modes - 3 == 2  # two nontrivial first-order modes
    # Away from it, on the conformations the motion visits either side, one rank more.
    for i in (0, 2):
        y = normalised(np.asarray(body["conformations"][i], dtype=float))
        t = np.linalg.svd(compatibility(y, edges), compute_uv=False)
        assert t[-1] / t[0] >= 1e-4


def test_both_tangents_satisfy_the_second_order_condition(at_branch):
    x, edges, b = at_branch
    c = compatibility(x, edges)
    u, s, vt = np.linalg.svd(c)
    omega = u[:, -1]  # the self-stress: Cᵀω = 0
    assert np.linalg.norm(c.T @ omega) <= 1e-12 * s[0]
    null = vt[len(edges) - 1 :].T
    modes = null - rigid(x) @ (rigid(x).T @ null)
    modes = np.linalg.svd(modes, full_matrices=False)[0][:, :2]  # the two nontrivial modes
    tangents = [np.asarray(b[k], dtype=float) for k in ("taken_tangent", "other_tangent")]
    scale = max(abs(second_order(omega, modes[:, i].reshape(x.shape), edges)) for i in (0, 1))
    for t in tangents:
        assert np.linalg.norm(t) == pytest.approx(1.0, rel=1e-9)
        assert np.linalg.norm(c @ t.ravel()) <= 1e-9 * s[0]  # a first-order zero mode
        assert np.linalg.norm(rigid(x).T @ t.ravel()) <= 1e-9  # not a rigid motion
        assert abs(second_order(omega, t, edges)) <= 1e-9 * scale
    # Q(a, b) on the two modes is indefinite and its root lines are exactly the two tangents.
    q = np.array([[second_order(omega, (modes[:, i] + modes[:, j]).reshape(x.shape), edges) for j in (0, 1)] for i in (0, 1)])
    diag = np.array([second_order(omega, modes[:, i].reshape(x.shape), edges) for i in (0, 1)])
    form = np.array([[diag[0], (q[0, 1] - diag[0] - diag[1]) / 2], [(q[0, 1] - diag[0] - diag[1]) / 2, diag[1]]])
    assert np.linalg.det(form) < 0
    angle = np.degrees(np.arccos(abs(float(np.sum(tangents[0] * tangents[1])))))
    assert angle == pytest.approx(b["angle_degrees"], abs=1e-6) and angle >= 10


def test_both_branches_keep_every_rod_and_are_different_curves(at_branch):
    x, edges, b = at_branch
    h, steps = 0.004, 8
    ends = {}
    for name in ("taken_tangent", "other_tangent"):
        t = np.asarray(b[name], dtype=float)
        for sign in (1.0, -1.0):
            path = branch_steps(x, edges, sign * t, h, steps)
            ref = bar_lengths(x, edges)
            for y in path:
                assert np.max(np.abs(bar_lengths(y, edges) - ref) / ref) <= 1e-10
            travelled = np.sqrt(np.mean(np.sum((path[-1] - x) ** 2, axis=1)))
            assert travelled >= 0.9 * h * steps / np.sqrt(len(x))  # a finite motion, not a stall
            ends[name, sign] = path
    # The other branch's configurations stay away from the taken branch's, and vice versa.
    for sign in (1.0, -1.0):
        other_end = ends["other_tangent", sign][-1]
        nearest = min(rigid_distance(other_end, y) for s in (1.0, -1.0) for y in ends["taken_tangent", s])
        assert nearest >= 0.05 * np.linalg.norm(other_end - x)


def test_stated_branch_reaches_the_next_conformation(body, at_branch):
    x, edges, b = at_branch
    conformations = np.asarray(body["conformations"], dtype=float)
    raw = conformations[BRANCH]
    radius = np.sqrt(np.mean(np.sum((raw - raw.mean(axis=0)) ** 2, axis=1)))
    target = (conformations[BRANCH + 1] - raw.mean(axis=0)) / radius
    scale = np.linalg.norm(target - x)
    h = 0.01
    path = branch_steps(x, edges, np.asarray(b["taken_tangent"], dtype=float), h, 1)
    best = (np.inf, None)
    for _ in range(200):
        d = rigid_distance(path[-1], target)
        if d > best[0]:
            break
        best = (d, path[-2:])
        path = branch_steps(path[-1], edges, path[-1] - path[-2], h, 1)
    # Polish between the neighbours of the closest sample on the curve itself.
    y0, y1 = best[1]

    def along(s):
        return rigid_distance(branch_steps(y0, edges, y1 - y0, s, 1)[-1], target) if s > 0 else rigid_distance(y0, target)

    polished = minimize_scalar(along, bounds=(1e-9, 2 * h), method="bounded", options={"xatol": 1e-13})
    assert min(best[0], polished.fun) / scale <= 1e-6
    # The stated sign: the taken tangent points towards the next conformation.
    assert np.sum(np.asarray(b["taken_tangent"]) * (target - x)) > 0


def test_the_other_conformations_are_the_minima(body):
    edges = np.asarray(body["frame"]["edges"])
    springs = body["springs"]
    pairs = np.asarray(springs["pairs"], dtype=int)
    assert [m["index"] for m in body["minima"]] == [0, 2]
    for m in body["minima"]:
        c = np.asarray(body["conformations"][m["index"]], dtype=float)
        kkt, curvature = constrained_curvature(c, edges, pairs, springs["stiffness"], springs["rest_length"])
        assert kkt <= 1e-7 and curvature > 0 and m["hessian_min_eigenvalue"] > 0
    b = body["bifurcation"]
    e = np.asarray(body["landscape"]["energy"])
    s = np.asarray(body["landscape"]["arclength"])
    at = body["landscape"]["conformation_samples"]
    assert s[at[0]] < b["arclength"] < s[at[1]]  # the branch point lies between the two minima
    assert body["report"]["analysis"]["self_stresses"] == 0  # conformation 0 is regular
    assert e[at[0] : at[1] + 1].max() - max(e[at[0]], e[at[1]]) >= body["report"]["barrier"] * (1 - 1e-9)


def test_bifurcation_needs_three_planar_conformations():
    with pytest.raises(DomainError) as err:
        zm.multistable(CONFORMATIONS[:2], bifurcation=0)
    assert err.value.code == "invalid_bifurcation"
