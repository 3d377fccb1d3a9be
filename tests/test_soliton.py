"""The soliton (zeromode.solver.sequential.soliton, issue 41 item 2), checked through independent
routes written here:

* the module's map f by a plain scipy solve of its bar-length equations (input pair pinned at
  (0, 0) and (d, 0), the other nodes by scipy.optimize.root, followed from the module's
  reference in small steps of d), iterated and compared with the chain's conformation at the
  drive samples;
* the wall position from those iterates by its definition (where (d_k − d_u)/(d_s − d_u)
  crosses ½), its monotone travel and its slope against −1/ln f′(d_u) (the linearisation);
* the springs' energy E = Σ k(|x_i − x_j| − L)²/2 from the definition (oracles.elastic), zero
  in both uniform states and positive along the drive;
* both uniform states minima: the Hessian of rods-as-stiff-springs plus springs by central
  differences of the hand gradient (oracles.elastic), positive definite modulo rigid motions,
  and the rods-as-constraints curvature along the chain's one flex.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.elastic import constrained_curvature, energy, hessian
from oracles.motion import bar_lengths
from oracles.rigidity import rigid_motions
from scipy.optimize import brentq, root

import zeromode as zm
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.sequential.design import MapPoint
from zeromode.solver.sequential.soliton import design_soliton, wall_position

N_MODULES = 16
POINTS = (MapPoint(1.2, 1.2, 1.8), MapPoint(1.8, 1.8, 0.4))
# Steps of the test's own continuation of the module along d_in.
GRID_STEP = 0.005


@pytest.fixture(scope="module")
def result():
    return design_soliton(POINTS, n_modules=N_MODULES)


class ScipyMap:
    """f of a planar module from its bar lengths: node a at (0, 0), node b at (d, 0), the others
    by scipy.optimize.root on |x_i − x_j| = l_e (as many equations as unknowns for a one-mode
    module with B = 2N − 4 bars), warm-started from a table of configurations followed from the
    reference in steps of GRID_STEP (one branch)."""

    def __init__(self, positions, edges, input_pair, output_pair, lo, hi):
        x = np.asarray(positions, dtype=float)
        self.edges = np.asarray(edges)
        self.lengths = bar_lengths(x, self.edges)
        (self.a, self.b), self.out = input_pair, output_pair
        self.free = [i for i in range(len(x)) if i not in input_pair]
        u = (x[self.b] - x[self.a]) / np.linalg.norm(x[self.b] - x[self.a])
        x = (x - x[self.a]) @ np.array([[u[0], -u[1]], [u[1], u[0]]])  # a at 0, b on +x
        d_ref = float(x[self.b, 0])
        self.grid, self.table = [d_ref], [x]
        for end in (lo, hi):
            y, d = x, d_ref
            while (end - d) * np.sign(end - d_ref) > 0:
                d = d + np.sign(end - d_ref) * min(GRID_STEP, abs(end - d))
                y = self.solve(d, y)
                self.grid.append(d)
                self.table.append(y)
        order = np.argsort(self.grid)
        self.grid = np.asarray(self.grid)[order]
        self.table = [self.table[i] for i in order]

    def solve(self, d: float, start: np.ndarray) -> np.ndarray:
        def placed(z):
            y = np.array(start, dtype=float)
            y[self.a], y[self.b] = (0.0, 0.0), (d, 0.0)
            y[self.free] = z.reshape(-1, 2)
            return y

        sol = root(lambda z: bar_lengths(placed(z), self.edges) - self.lengths, start[self.free].ravel(),
                   method="hybr", options={"xtol": 1e-15})
        y = placed(sol.x)
        assert np.max(np.abs(bar_lengths(y, self.edges) - self.lengths)) < 1e-12
        return y

    def configuration(self, d: float) -> np.ndarray:
        return self.solve(d, self.table[int(np.argmin(np.abs(self.grid - d)))])

    def __call__(self, d: float) -> float:
        y = self.configuration(d)
        return float(np.linalg.norm(y[self.out[0]] - y[self.out[1]]))

    def orbit(self, d0: float, n: int) -> np.ndarray:
        out = [d0]
        for _ in range(n):
            out.append(self(out[-1]))
        return np.asarray(out)


@pytest.fixture(scope="module")
def scipy_map(result):
    module = result.soliton.module
    return ScipyMap(module.frame.positions, module.frame.edges, module.input_pair, module.output_pair, 1.1, 1.9)


def test_wall_position_by_hand():
    # s = (0, 0, 1/6, 2/3, 1): ½ is crossed between copies 2 and 3, a third of the way … ⅔
    assert wall_position(np.array([1.2, 1.2, 1.3, 1.6, 1.8]), 1.2, 1.8) == pytest.approx(2 + (1 / 3) / (1 / 2), rel=1e-14)
    assert np.isnan(wall_position(np.array([1.2, 1.25, 1.3]), 1.2, 1.8))  # never switched: the wall is beyond
    assert np.isnan(wall_position(np.array([1.6, 1.7, 1.8]), 1.2, 1.8))  # all switched: the wall is before


def test_fixed_points_are_those_of_the_scipy_map(result, scipy_map):
    sol = result.soliton
    for (d, slope), asked in zip((sol.unstable, sol.stable), POINTS):
        star = brentq(lambda x: scipy_map(x) - x, asked.d_in - 0.05, asked.d_in + 0.05, xtol=1e-15)
        assert d == pytest.approx(star, rel=1e-12)
        h = 1e-6
        assert (scipy_map(star + h) - scipy_map(star - h)) / (2 * h) == pytest.approx(slope, rel=1e-6)
        assert slope == pytest.approx(asked.slope, rel=1e-8)


def test_chain_conformation_is_the_orbit_of_the_scipy_map(result, scipy_map):
    sol = result.soliton
    d_u, d_s = sol.unstable[0], sol.stable[0]
    assert np.all((sol.drive - d_u) * (d_s - sol.drive) > 0) and np.all(np.diff(np.abs(sol.drive - d_u)) > 0)
    picks = np.linspace(0, len(sol.drive) - 1, 40).astype(int)
    walls = []
    for i in picks:
        orbit = scipy_map.orbit(sol.drive[i], N_MODULES)
        assert np.max(np.abs(orbit - sol.distances[i]) / orbit) <= 1e-8
        # the wall from the definition, on the scipy iterates
        s = (orbit - d_u) / (d_s - d_u)
        up = [k for k in range(N_MODULES) if s[k] < 0.5 <= s[k + 1]]
        walls.append(up[0] + (0.5 - s[up[0]]) / (s[up[0] + 1] - s[up[0]]) if up else np.nan)
    walls = np.asarray(walls)
    assert walls == pytest.approx(sol.wall[picks], abs=1e-6, nan_ok=True)
    placed = walls[np.isfinite(walls)]
    assert np.all(np.diff(placed) < 0)  # d_0 leaves d_u: the wall walks towards the input, monotonically
    assert placed.max() - placed.min() >= N_MODULES - 2.5  # the picks are a subset of the drive
    assert sol.travel >= sol.required_travel == N_MODULES - 2 and sol.monotone
    # linearised at d_u: w ≈ const − ln|d_0 − d_u| / ln f′(d_u), in the bulk of the chain
    bulk = np.isfinite(walls) & (walls > 2) & (walls < N_MODULES - 2)
    slope = np.polyfit(np.log(np.abs(sol.drive[picks][bulk] - d_u)), walls[bulk], 1)[0]
    assert slope == pytest.approx(-1 / np.log(POINTS[0].slope), rel=0.1)


def test_a_steeper_map_gives_a_sharper_wall():
    # f′(d_u) = 2.5, f′(d_s) = 0.3 on 12 copies: the same checks by the scipy map, the wall's
    # slope against ln|d_0 − d_u| now −1/ln 2.5
    result = design_soliton((MapPoint(1.3, 1.3, 2.5), MapPoint(1.7, 1.7, 0.3)), n_modules=12)
    sol, module = result.soliton, result.soliton.module
    f = ScipyMap(module.frame.positions, module.frame.edges, module.input_pair, module.output_pair, 1.29, 1.71)
    d_u, d_s = sol.unstable[0], sol.stable[0]
    picks = np.linspace(0, len(sol.drive) - 1, 20).astype(int)
    walls = []
    for i in picks:
        orbit = f.orbit(sol.drive[i], 12)
        assert np.max(np.abs(orbit - sol.distances[i]) / orbit) <= 1e-8
        walls.append(wall_position(orbit, d_u, d_s))
    walls = np.asarray(walls)
    placed = walls[np.isfinite(walls)]
    assert np.all(np.diff(placed) < 0) and sol.travel >= 10 and sol.monotone
    bulk = np.isfinite(walls) & (walls > 2) & (walls < 10)
    slope = np.polyfit(np.log(np.abs(sol.drive[picks][bulk] - d_u)), walls[bulk], 1)[0]
    assert slope == pytest.approx(-1 / np.log(2.5), rel=0.1)
    assert np.all(sol.uniform_hessian > 0) and np.max(sol.uniform_energy) < 1e-20


def test_spring_is_at_rest_at_both_fixed_points_and_not_between(result, scipy_map):
    sol = result.soliton
    anchor, node = sol.module.frame.n_nodes - 1, sol.spring_node
    rest = sol.springs.rest_length[0]

    def length(d):
        y = scipy_map.configuration(d)
        return np.linalg.norm(y[anchor] - y[node])

    assert length(sol.unstable[0]) == pytest.approx(rest, rel=1e-10)
    assert length(sol.stable[0]) == pytest.approx(rest, rel=1e-10)
    gaps = [length(d) - rest for d in np.linspace(sol.unstable[0], sol.stable[0], 12)[1:-1]]
    assert all(g > 1e-3 * rest for g in gaps) or all(g < -1e-3 * rest for g in gaps)


def test_energy_along_the_drive_from_the_definition(result):
    sol, verified = result.soliton, result.chain
    pairs, k, rest = sol.springs.pairs, sol.springs.stiffness, sol.springs.rest_length
    assert len(pairs) == N_MODULES and not {tuple(sorted(p)) for p in pairs.tolist()} & {
        tuple(sorted(e)) for e in verified.chain.frame.edges.tolist()}
    for i in range(0, len(sol.drive), 7):
        x = verified.positions[sol.rows[i]]
        assert np.linalg.norm(x[verified.chain.pairs[:, 0]] - x[verified.chain.pairs[:, 1]], axis=1) == pytest.approx(
            sol.distances[i], rel=1e-14)
        assert energy(x, pairs, k, rest) == pytest.approx(sol.energy[i], rel=1e-10, abs=1e-15)
    assert np.all(sol.energy > 0)
    # the wall far from both ends costs the same wherever it is (the soliton's energy; its
    # stretched springs reach about six copies past the crossing towards the far end)
    bulk = np.isfinite(sol.wall) & (sol.wall > 5) & (sol.wall < N_MODULES - 6)
    assert np.ptp(sol.energy[bulk]) <= 0.01 * sol.barrier


def test_wall_point_from_the_definition(result):
    """c(w): pair k's and pair k + 1's midpoints interpolated at the fractional index w, written
    here sample by sample (the designer draws the wall there); NaN exactly where the wall is."""
    sol, verified = result.soliton, result.chain
    pairs = verified.chain.pairs
    assert sol.wall_point.shape == (len(sol.drive), 2)
    assert np.array_equal(np.isnan(sol.wall_point).any(axis=1), np.isnan(sol.wall))
    for i in np.flatnonzero(np.isfinite(sol.wall))[::5]:
        x, w = verified.positions[sol.rows[i]], sol.wall[i]
        k = min(int(w), len(pairs) - 2)
        a = (x[pairs[k, 0]] + x[pairs[k, 1]]) / 2
        b = (x[pairs[k + 1, 0]] + x[pairs[k + 1, 1]]) / 2
        assert sol.wall_point[i] == pytest.approx(a + (w - k) * (b - a), abs=1e-12)


def test_both_uniform_states_are_strict_minima(result, scipy_map):
    sol, chain = result.soliton, result.chain.chain
    edges = chain.frame.edges
    rods = bar_lengths(chain.frame.positions, edges)
    pairs = np.vstack([edges, sol.springs.pairs])
    k = sol.springs.stiffness[0]
    stiffness = np.concatenate([np.full(len(edges), sol.rod_stiffness_ratio * k), sol.springs.stiffness])
    rest = np.concatenate([rods, sol.springs.rest_length])
    for j, (d, _) in enumerate((sol.unstable, sol.stable)):
        x = sol.uniform[j]
        assert bar_lengths(x, edges) == pytest.approx(rods, rel=1e-11)
        d_pairs = np.linalg.norm(x[chain.pairs[:, 0]] - x[chain.pairs[:, 1]], axis=1)
        assert d_pairs == pytest.approx(np.full(N_MODULES + 1, d), rel=1e-9)
        assert energy(x, sol.springs.pairs, sol.springs.stiffness, sol.springs.rest_length) < 1e-20
        r = rigid_motions(x)
        q = np.linalg.svd(np.eye(x.size) - r @ r.T)[0][:, : x.size - r.shape[1]]
        smallest = np.linalg.eigvalsh(q.T @ hessian(x, pairs, stiffness, rest) @ q)[0]
        assert smallest > 0
        assert smallest == pytest.approx(sol.uniform_hessian[j], rel=1e-3)
        _, curvature = constrained_curvature(x, edges, sol.springs.pairs, sol.springs.stiffness, sol.springs.rest_length)
        assert curvature > 0


def test_refusals():
    with pytest.raises(InvalidInput) as one:
        design_soliton((MapPoint(1.2, 1.2, 1.8),))
    assert one.value.code == "invalid_soliton"
    with pytest.raises(InvalidInput) as two_stable:
        design_soliton((MapPoint(1.2, 1.2, 0.5), MapPoint(1.8, 1.8, 0.4)))
    assert two_stable.value.code == "invalid_soliton"
    with pytest.raises(InvalidInput) as alternating:
        design_soliton((MapPoint(1.2, 1.2, 1.8), MapPoint(1.8, 1.8, -0.4)))
    assert alternating.value.code == "invalid_soliton"
    with pytest.raises(InvalidInput) as short:
        design_soliton(POINTS, n_modules=3)
    assert short.value.code == "invalid_modules"
    with pytest.raises(DomainError) as long:  # the drive would need d_0 − d_u below round-off
        design_soliton(POINTS, n_modules=64)
    assert long.value.code == "soliton_out_of_reach" and "59.0" in long.value.message
    with pytest.raises(InvalidInput) as both:
        zm.sequential([{"kind": "fixed_point", "d": 1.2, "slope": 1.8}, {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
                      n_modules=8, soliton={"n_modules": 8})
    assert both.value.code == "invalid_soliton"


def test_library_soliton_and_its_picture():
    s = zm.sequential([{"kind": "fixed_point", "d": 1.2, "slope": 1.8}, {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
                      soliton={"n_modules": 6, "stiffness": 0.5})
    body = s.to_dict()
    sol = body["soliton"]
    assert body["chain"] is not None and len(sol["springs"]["pairs"]) == 6 and set(sol["springs"]["stiffness"]) == {0.5}
    assert sol["travel"] >= sol["required_travel"] == 4
    figure = s.plot()
    chains = [a for a in figure.get_axes() if a.get_title().startswith("d₀ − d_u")]
    assert len(chains) == len(sol["snapshots"]) == 4
    for axes, j in zip(chains, sol["snapshots"]):
        assert f"wall at copy {sol['wall'][j]:.1f}" in axes.get_title()
