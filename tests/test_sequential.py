"""Modules as one-dimensional maps (zeromode.solver.sequential, issue 41 item 2), checked
through independent routes:

* the two-triangle module's map in closed form: triangles (0, 2, 4) and (1, 3, 4) hinged at
  node 4; turning triangle B by θ about the hinge gives d_in(θ) = |r₀ − R(θ)r₁|,
  d_out(θ) = |r₂ − R(θ)r₃| (r_i = X_i − X_4), folds where r₀ ∥ R(θ)r₁;
* a plain numpy continuation written here (Newton on the bar lengths while stepping d_in) for
  a four-bar whose diagonals are the pairs;
* finite differences of f for f′;
* a chain's distances against the closed-form f of one module.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.two_triangles import TwoTriangles

from zeromode.solver.analysis.rigidity import analyze
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.sequential.chain import chain_of, verify_chain
from zeromode.solver.sequential.design import design_module, fixed_point, period_two, range_onto
from zeromode.solver.sequential.module_map import Module, module_map, two_triangle_module


@pytest.fixture(scope="module")
def start_map():
    return module_map(two_triangle_module())


def test_map_of_the_two_triangle_module_is_its_closed_form(start_map):
    exact = TwoTriangles(start_map.module.frame.positions)
    lo, hi = exact.range()
    assert start_map.range == pytest.approx((lo, hi), rel=1e-9)
    assert {start_map.lower.kind, start_map.upper.kind} == {"fold"}
    for end in (start_map.lower, start_map.upper):
        t = exact.lo if abs(exact.d_in(exact.lo) - end.d_in) < abs(exact.d_in(exact.hi) - end.d_in) else exact.hi
        assert end.d_out == pytest.approx(exact.d_out(t), rel=1e-7)
    # every sample of the continuation lies on the closed-form graph
    inner = (start_map.d_in > lo + 1e-6) & (start_map.d_in < hi - 1e-6)
    assert np.max(np.abs([exact.f(x) - y for x, y in zip(start_map.d_in[inner], start_map.d_out[inner])])) < 1e-9
    assert np.all(np.diff(start_map.d_in) > 0)
    # exact evaluation, its slope and finite differences
    xs = np.linspace(lo, hi, 9)[1:-1]
    values, slopes = start_map.evaluate(xs)
    assert values == pytest.approx([exact.f(x) for x in xs], rel=1e-11)
    assert slopes == pytest.approx([exact.slope(x) for x in xs], rel=1e-8, abs=1e-10)
    h = 1e-6
    fd = (start_map.evaluate(xs + h)[0] - start_map.evaluate(xs - h)[0]) / (2 * h)
    assert slopes == pytest.approx(fd, rel=1e-6, abs=1e-8)
    # the sampled slopes (null space of C at each sample) agree too
    assert start_map.slope[inner] == pytest.approx([exact.slope(x) for x in start_map.d_in[inner]], rel=1e-6, abs=1e-8)


def test_fixed_points_are_where_the_closed_form_crosses_the_diagonal(start_map):
    exact = TwoTriangles(start_map.module.frame.positions)
    found = start_map.fixed_points()
    assert found
    for star, slope in found:
        assert exact.f(star) == pytest.approx(star, rel=1e-12)
        assert slope == pytest.approx(exact.slope(star), rel=1e-8)


def _newton_continuation(positions, edges, pair_in, pair_out, targets):
    """d_out at each d_in in ``targets`` (ascending from the reference's d_in), by stepping d_in
    and solving the bar lengths, d_in and a pinned gauge (node 0 fixed, node 1's y fixed) by
    Newton's method (least squares) from the previous configuration."""
    x = np.asarray(positions, dtype=float).copy()
    lengths2 = np.sum((x[edges[:, 0]] - x[edges[:, 1]]) ** 2, axis=1)
    gauge = np.concatenate([x[0], x[1, 1:]])
    out = []
    for d in targets:
        for _ in range(50):
            diff = x[edges[:, 0]] - x[edges[:, 1]]
            res = [np.sum(diff**2, axis=1) - lengths2, [np.sum((x[pair_in[0]] - x[pair_in[1]]) ** 2) - d**2],
                   np.concatenate([x[0], x[1, 1:]]) - gauge]
            jac = np.zeros((len(edges) + 4, x.size))
            for k, (i, j) in enumerate(edges):
                jac[k, 2 * i:2 * i + 2] = 2 * diff[k]
                jac[k, 2 * j:2 * j + 2] = -2 * diff[k]
            a, b = pair_in
            jac[len(edges), 2 * a:2 * a + 2] = 2 * (x[a] - x[b])
            jac[len(edges), 2 * b:2 * b + 2] = -2 * (x[a] - x[b])
            jac[len(edges) + 1, 0] = jac[len(edges) + 2, 1] = jac[len(edges) + 3, 3] = 1.0
            step = np.linalg.lstsq(jac, -np.concatenate(res), rcond=None)[0]
            x += step.reshape(x.shape)
            if np.max(np.abs(step)) < 1e-15:
                break
        out.append(np.linalg.norm(x[pair_out[0]] - x[pair_out[1]]))
    return np.array(out)


def test_four_bar_map_matches_a_plain_newton_continuation():
    positions = np.array([[0.0, 0.0], [1.2, 0.1], [1.5, 1.3], [0.1, 0.9]])
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    module = Module.build(Frame.build(positions, edges), (0, 2), (1, 3))
    the_map = module_map(module)
    d_ref = np.linalg.norm(positions[2] - positions[0])
    up = np.linspace(d_ref, the_map.range[1], 40)[:-3]
    down = np.linspace(d_ref, the_map.range[0], 40)[:-3]
    for targets in (up, down):
        assert the_map.evaluate(targets)[0] == pytest.approx(
            _newton_continuation(positions, edges, (0, 2), (1, 3), targets), rel=1e-10)


@pytest.mark.parametrize(
    "points",
    [fixed_point(1.5, -0.5), fixed_point(1.2, 1.8), period_two(1.3, 1.7), range_onto((1.0, 1.5), (1.2, 2.0)),
     fixed_point(1.2, 1.8) + fixed_point(1.8, 0.4)],
    ids=["stable_fixed_point", "unstable_fixed_point", "period_two", "range_onto", "deployable"],
)
def test_designed_module_meets_its_feature_in_closed_form(points):
    design = design_module(points)
    exact = TwoTriangles(design.module.frame.positions)
    for p in points:
        assert exact.f(p.d_in) == pytest.approx(p.d_out, rel=1e-8)
        if p.slope is not None:
            assert exact.slope(p.d_in) == pytest.approx(p.slope, rel=1e-8)
            h = 1e-6
            fd = (exact.f(p.d_in + h) - exact.f(p.d_in - h)) / (2 * h)
            assert fd == pytest.approx(p.slope, rel=1e-5)
    assert design.deviation <= 1e-8
    # the chosen stability is the slope's: an orbit started near a stable fixed point converges
    for p in points:
        if p.slope is not None and abs(p.slope) < 1 and p.d_in == p.d_out:
            orbit = design.map.iterate(p.d_in + 1e-3, 60)
            assert abs(orbit[-1] - p.d_in) < 1e-6


def test_features_out_of_reach_are_refused_with_the_best_figures():
    # nodes within reach·r of the centre are at most 2·reach·r apart: refused before any work
    r = np.sqrt(np.mean(np.sum((two_triangle_module().frame.positions - two_triangle_module().frame.positions.mean(0)) ** 2, 1)))
    with pytest.raises(DomainError) as far:
        design_module(fixed_point(2 * 3.0 * r * 1.01, 0.5))
    assert far.value.code == "feature_out_of_reach" and "out of reach" in far.value.message
    with pytest.raises(DomainError) as steep:
        design_module(fixed_point(1.2, 40.0))
    assert steep.value.code == "feature_out_of_reach"
    assert steep.value.best.configurations.shape == (1, 5, 2)
    assert steep.value.best.deviation > 1e-8
    # the best module's own map, evaluated independently, shows the figure reported
    exact = TwoTriangles(steep.value.best.module.frame.positions) if steep.value.best.map is not None else None
    if exact is not None and exact.range()[0] < 1.2 < exact.range()[1]:
        assert steep.value.best.slopes[0] == pytest.approx(exact.slope(1.2), rel=1e-8)
    with pytest.raises(DomainError) as wide:
        design_module(range_onto((0.5, 15.0), (0.6, 15.0)), reach=100.0)  # 300 inputs apart
    assert wide.value.code == "too_expensive"
    with pytest.raises(InvalidInput) as same:
        design_module(period_two(1.3, 1.3))
    assert same.value.code == "invalid_feature"


def test_bad_modules_are_refused():
    frame = two_triangle_module().frame
    with pytest.raises(InvalidInput, match="is a bar"):
        Module.build(frame, (0, 2), (1, 3))
    with pytest.raises(InvalidInput):
        Module.build(frame, (0, 0), (2, 3))
    # a two-triangle module whose reference has r₀ ∥ r₁ (hinge on the input line): a fold
    folded = Module.build(Frame.build([[-1, 0], [1, 0], [-0.8, 1], [0.8, 1], [0.2, 0]], frame.edges), (0, 1), (2, 3))
    with pytest.raises(DomainError) as fold:
        module_map(folded)
    assert fold.value.code == "reference_at_fold"
    ladder = Frame.build([[float(i // 2), float(i % 2)] for i in range(202)],
                         [[i, i + 2] for i in range(200)] + [[i, i + 1] for i in range(0, 202, 2)])
    with pytest.raises(DomainError) as big:
        module_map(Module.build(ladder, (0, 3), (198, 201)))
    assert big.value.code == "too_expensive"
    with pytest.raises(DomainError) as big_start:
        design_module(fixed_point(1.5, -0.5), start=Module.build(ladder, (0, 3), (198, 201)))
    assert big_start.value.code == "too_expensive"
    rigid = Frame.build([[0, 0], [1, 0], [0, 1], [1, 1]], [[0, 1], [0, 2], [1, 3], [2, 3], [0, 3]])
    with pytest.raises(DomainError):
        module_map(Module.build(rigid, (1, 2), (0, 3)))


@pytest.fixture(scope="module")
def deployable():
    """A module with an unstable fixed point 1.2 (f′ = 1.8) and a stable one 1.8 (f′ = 0.4)."""
    return design_module(fixed_point(1.2, 1.8) + fixed_point(1.8, 0.4))


def test_chain_conformation_is_the_orbit_of_the_closed_form_map(deployable):
    design = deployable
    exact = TwoTriangles(design.module.frame.positions)
    n = 10
    chain = chain_of(design.map, n, 1.25)
    assert chain.frame.n_nodes == 5 + 3 * (n - 1) and chain.frame.n_edges == 6 * n
    assert analyze(chain.frame).nontrivial_zero_modes == 1
    built = chain.distances(chain.frame.positions)
    orbit = [1.25]
    for _ in range(n):
        orbit.append(exact.f(orbit[-1]))
    assert built == pytest.approx(orbit, rel=1e-10)
    result = verify_chain(chain, design.map)
    d = result.distances
    assert len(d) > 20 and result.deviation <= 1e-8
    lo, hi = exact.range()
    worst = max(abs(exact.f(d[p, k]) - d[p, k + 1]) / d[p, k + 1]
                for p in range(len(d)) for k in range(n) if lo < d[p, k] < hi)
    assert worst <= 1e-8
    # deployable: within 0.01 of the unstable fixed point at the input, the far end spans most
    # of the way from the range's lower end to the stable fixed point 1.8
    near = np.abs(d[:, 0] - 1.2) < 0.01
    assert np.ptp(d[near, -1]) > 0.5
    # The conformation along the motion (what the viewer animates): every bar at its length, the
    # pairs' distances read from it are the reported d_k, and the reference sample is the chain built.
    x, edges = result.positions, chain.frame.edges
    assert x.shape == (len(d), chain.frame.n_nodes, 2)
    length = lambda p: np.linalg.norm(p[edges[:, 0]] - p[edges[:, 1]], axis=1)
    assert max(np.abs(length(p) / length(chain.frame.positions) - 1).max() for p in x) <= 1e-9
    pairs = chain.pairs
    assert np.allclose(np.linalg.norm(x[:, pairs[:, 0]] - x[:, pairs[:, 1]], axis=-1), d, rtol=1e-12)
    assert np.array_equal(x[result.reference_index], chain.frame.positions)


def test_chain_refusals(deployable):
    with pytest.raises(InvalidInput):
        chain_of(deployable.map, 0)
    exact = TwoTriangles(deployable.module.frame.positions)
    assert exact.f(1.15) < 1.15  # below the unstable fixed point the orbit falls out of the range
    with pytest.raises(DomainError) as leaves:
        chain_of(deployable.map, 40, 1.15)
    assert leaves.value.code == "chain_leaves_range"
