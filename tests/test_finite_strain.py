"""Sheets holding their secant Poisson ratio over a strain range, checked from positions.

Independent routes: the boundary sets are found here from the geometry (corner rows and
columns), the secant ν of every configuration from their mean positions, bar lengths
recomputed, the rank of the tiled sheet's compatibility matrix by numpy's SVD, and the sheet's
own finite motion traced on the full frame by continuation (not the module's Newton solves the
design used).
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.motion import boundary_strains, relative_bar_error
from oracles.rigidity import zero_modes_and_stresses

from zeromode.solver.applications.finite_strain import FiniteStrainUnreachable, finite_strain_sheet
from zeromode.solver.errors import InvalidInput
from zeromode.solver.motion.finite_motion import trace_motion
from zeromode.solver.pipeline import auxetic_pipeline


def corner_sets(x: np.ndarray, nx: int, ny: int) -> dict:
    """The corner grid's boundary rows and columns (corners come first, (n_x+1)(n_y+1) of them)."""
    corners = np.arange((nx + 1) * (ny + 1))
    cx, cy = x[corners, 0], x[corners, 1]
    return {
        "left": corners[np.isclose(cx, cx.min())],
        "right": corners[np.isclose(cx, cx.max())],
        "bottom": corners[np.isclose(cy, cy.min())],
        "top": corners[np.isclose(cy, cy.max())],
    }


@pytest.fixture(scope="module")
def held():
    return finite_strain_sheet(3, 3, poisson=-0.5, strain_range=(-0.1, 0.1), tolerance=0.02)


def strains_along_own_motion(lat, cells: tuple[int, int], nu: float, tol: float, amplitude: float, max_step: float,
                             each=None) -> None:
    """The tiled sheet is one mechanism (4 zero modes, by an independent rank count); its own
    motion, traced on the full frame, keeps every bar length and ν_secant within ``tol`` of
    ``nu`` wherever 1e-3 < |ε_x| ≤ 0.1, and covers ε_x beyond ±0.09; ``each(config, ε_x, ε_y)``
    checks more at each of those configurations."""
    x, edges = lat.frame.positions, lat.frame.edges
    zero_modes, _ = zero_modes_and_stresses(x, edges)
    assert zero_modes == 4  # 3 rigid + the one mechanism
    sets = corner_sets(x, *cells)
    path = trace_motion(lat.frame, lat.mode, amplitude=amplitude, max_step=max_step)
    assert relative_bar_error(path.positions, edges, x) <= 1e-9
    seen = []
    for config in path.positions:
        ex, ey = boundary_strains(x, config, sets, finite=True)
        if 1e-3 < abs(ex) <= 0.1:
            seen.append(ex)
            assert abs(-ey / ex - nu) <= tol, ex
            if each is not None:
                each(config, ex, ey)
    assert min(seen) < -0.09 and max(seen) > 0.09


def test_held_sheet_is_one_mechanism_and_keeps_nu_along_its_own_motion(held):
    lat = held.lattice
    sets = corner_sets(lat.frame.positions, 3, 3)
    assert {k: set(v) for k, v in lat.boundary.items()} == {k: set(v.tolist()) for k, v in sets.items()}
    strains_along_own_motion(lat, (3, 3), -0.5, 0.02, amplitude=0.1, max_step=0.002)


def test_held_sheet_states_and_report(held):
    lat = held.lattice
    x, edges = lat.frame.positions, lat.frame.edges
    sets = corner_sets(x, 3, 3)
    for name, (state, nu, eps) in lat.states.items():
        assert relative_bar_error([state], edges, x) <= 1e-9
        ex, ey = boundary_strains(x, state, sets, finite=True)
        assert abs(ex - (0.1 if name == "expanded" else -0.1)) <= 1e-12
        assert abs(-ey / ex - nu) <= 1e-12 and abs(nu + 0.5) <= 0.02
    assert held.max_deviation <= 0.02 and np.all(np.abs(held.secant_ratios + 0.5) <= 0.02)
    assert lat.strain_range.lower.strain <= -0.1 and lat.strain_range.upper.strain >= 0.1


def test_unreachable_tolerance_answers_with_the_best_figures():
    with pytest.raises(FiniteStrainUnreachable) as err:
        finite_strain_sheet(2, 2, poisson=-0.5, strain_range=(-0.1, 0.1), tolerance=1e-6)
    assert err.value.code == "finite_strain_unreachable"
    best = err.value.best["best_deviation"]
    assert 1e-6 < best["max_deviation"] < 1e-3
    # IPOPT's refinement of the best module was tried and its figures are reported too.
    refined = err.value.best["refinement"]
    assert refined["max_deviation"] > 1e-6 and 0 <= refined["cover"] <= 1


def test_refusals():
    with pytest.raises(InvalidInput) as err:
        auxetic_pipeline(3, (2,), poisson=-0.5, finite_strain=(-0.1, 0.1, 0.02))
    assert err.value.code == "invalid_options"
    with pytest.raises(InvalidInput) as err:
        finite_strain_sheet(2, 2, poisson=-0.5, strain_range=(0.05, 0.1), tolerance=0.02)
    assert err.value.code == "invalid_strain_range"
    with pytest.raises(InvalidInput) as err:
        finite_strain_sheet(51, 50, poisson=-0.5, strain_range=(-0.1, 0.1), tolerance=0.02)
    assert err.value.code == "invalid_size"


def test_over_http(client):
    refused = client.post(
        "/v1/design/auxetic",
        json={"cells": [2, 2], "poisson_ratio": -0.5, "finite_strain": {"strain_range": [-0.1, 0.1], "tolerance": 1e-6}},
    )
    assert refused.status_code == 422
    detail = refused.json()["detail"]
    assert detail["code"] == "finite_strain_unreachable" and detail["best"]["best_deviation"]["max_deviation"] > 1e-6
    report = held_over_http(client, (2, 2), -0.5, {"strain_range": [-0.1, 0.1]}, 0.02)
    assert report["max_deviation"] <= 0.02 and report["module"]["family"] == "trammel"
    # ν = −1: the Cardan trammel, its states at ±10 % with secant ν −1 to round-off.
    report = held_over_http(client, (2, 3), -1.0, {"strain_range": [-0.1, 0.1], "tolerance": 1e-3}, 1e-12)
    assert report["module"]["family"] == "cardan"


def held_over_http(client, cells: tuple[int, int], nu: float, finite_strain: dict, tol: float) -> dict:
    """POST /v1/design/auxetic with ``finite_strain``: its states sit at ε_x = ±10 % with secant ν
    within ``tol`` of ``nu``, measured here from the returned positions; the finite-strain report."""
    response = client.post("/v1/design/auxetic",
                           json={"cells": list(cells), "poisson_ratio": nu, "finite_strain": finite_strain})
    assert response.status_code == 200, response.text
    body = response.json()
    x = np.array(body["frame"]["positions"])
    sets = corner_sets(x, *cells)
    for state in body["states"]:
        ex, ey = boundary_strains(x, np.array(state["positions"]), sets, finite=True)
        assert abs(abs(ex) - 0.1) <= 1e-12 and abs(-ey / ex - nu) <= tol
    return body["report"]["finite_strain"]


def test_minus_one_is_held_exactly_by_a_cardan_trammel():
    """ν = −1 (out of the stretched trammels' reach): the corner rides a straight line through the
    module's centre, so the secant ν of the full sheet's own motion is −1 to round-off."""
    held = finite_strain_sheet(3, 2, poisson=-1.0, strain_range=(-0.1, 0.1), tolerance=0.02, cell=(1.0, 0.7))
    assert held.family == "cardan"
    strains_along_own_motion(held.lattice, (3, 2), -1.0, 1e-9, amplitude=0.2, max_step=0.004)


def closest_unjoined_fraction(x: np.ndarray, edges: np.ndarray) -> float:
    """min |X_i − X_j| over node pairs without a bar, over the shortest bar (brute force)."""
    d = np.linalg.norm(x[:, None] - x[None], axis=2)
    d[edges[:, 0], edges[:, 1]] = d[edges[:, 1], edges[:, 0]] = np.inf
    np.fill_diagonal(d, np.inf)
    return float(d.min() / np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1).min())


def test_ipopt_reaches_what_the_family_misses():
    """ν = −0.8 within ±0.02 over ±10 %: every trammel of the family within the tolerance
    collides inside the range; IPOPT's refinement of the best one holds it.  Checked on the
    full sheet from positions: one mechanism, the corner grid an affine image of the reference
    (the tiling stays consistent), bars kept, ν along the sheet's own motion, no collision."""
    held = finite_strain_sheet(3, 3, poisson=-0.8, strain_range=(-0.1, 0.1), tolerance=0.02)
    assert held.family == "refined"
    lat = held.lattice
    x, edges = lat.frame.positions, lat.frame.edges
    corners = np.arange(16)

    def affine_and_apart(config, ex, ey):
        # corners: X = diag(1 + ε_x, 1 + ε_y)·X₀ up to a translation and a rotation
        c0 = x[corners] - x[corners].mean(axis=0)
        c1 = config[corners] - config[corners].mean(axis=0)
        u, _, vt = np.linalg.svd(c1.T @ (c0 * [1 + ex, 1 + ey]))
        assert np.max(np.abs(c1 @ (u @ vt) - c0 * [1 + ex, 1 + ey])) <= 1e-8
        assert closest_unjoined_fraction(config, edges) >= 0.1

    strains_along_own_motion(lat, (3, 3), -0.8, 0.02, amplitude=0.2, max_step=0.004, each=affine_and_apart)
