"""The usable strain range of auxetic sheets and chains, checked from positions built here.

Independent route: the two-node module's finite motion in closed form (test_lattice.py's
derivation): with corners (±a, ±b) and nodes (±c', 0), the bars to the near and far corners keep
(c' − a)² + b² = L₁² and (c' + a)² + b² = L₂², so c' = (L₂² − L₁²)/(4a), b = √(L₁² − (c' − a)²).
The sheet at strain ε (a = w(1 + ε)) is tiled here from it; the closest pair of nodes without a
bar is found by brute force (scipy pdist), bar crossings by segment intersection, and the rank
of the compatibility matrix by numpy's SVD.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.motion import boundary_strains, relative_bar_error
from oracles.rigidity import compatibility_matrix, normalised
from scipy.spatial.distance import pdist, squareform

from zeromode.solver.applications.lattice import auxetic_chain_3d, auxetic_sheet
from zeromode.solver.tolerances import PROXIMITY_FRACTION


def sheet_at(nx, ny, w, h, c0, eps):
    """Sheet positions at strain ε from the closed form, corner grid then two nodes per module
    (the node order the sheet's frame uses), or None where the module has no configuration."""
    l1, l2 = (c0 - w) ** 2 + h**2, (c0 + w) ** 2 + h**2
    a = w * (1 + eps)
    c = (l2 - l1) / (4 * a)
    b2 = l1 - (c - a) ** 2
    if a <= 0 or b2 <= 0:
        return None
    b = np.sqrt(b2)
    gx, gy = np.meshgrid((2 * np.arange(nx + 1) - nx) * a, (2 * np.arange(ny + 1) - ny) * b)
    cx, cy = np.meshgrid((2 * np.arange(nx) + 1 - nx) * a, (2 * np.arange(ny) + 1 - ny) * b)
    centres = np.column_stack([cx.ravel(), cy.ravel()])
    inner = np.stack([centres + [c, 0], centres - [c, 0]], axis=1).reshape(-1, 2)
    return np.vstack([np.column_stack([gx.ravel(), gy.ravel()]), inner])


def closest_unjoined(x, edges):
    d = squareform(pdist(x))
    d[edges[:, 0], edges[:, 1]] = d[edges[:, 1], edges[:, 0]] = np.inf
    np.fill_diagonal(d, np.inf)
    return float(d.min())


def crossings(x, edges) -> int:
    """Pairs of bars without a common node whose segments intersect properly."""
    count = 0
    for i in range(len(edges)):
        p, r = x[edges[i, 0]], x[edges[i, 1]] - x[edges[i, 0]]
        for j in range(i + 1, len(edges)):
            if set(edges[i]) & set(edges[j]):
                continue
            q, s = x[edges[j, 0]], x[edges[j, 1]] - x[edges[j, 0]]
            den = r[0] * s[1] - r[1] * s[0]
            if abs(den) < 1e-14:
                continue
            t = ((q - p)[0] * s[1] - (q - p)[1] * s[0]) / den
            u = ((q - p)[0] * r[1] - (q - p)[1] * r[0]) / den
            count += 0 < t < 1 and 0 < u < 1
    return count


def sigma_ratio(x, edges) -> float:
    s = np.linalg.svd(compatibility_matrix(normalised(x), edges), compute_uv=False)
    return float(s[-1] / s[0])


@pytest.mark.parametrize(("nx", "ny", "poisson"), [(4, 4, -0.5), (3, 2, -1.0), (1, 1, -0.5), (2, 3, 0.3)])
def test_sheet_range_is_usable_inside_and_ends_where_it_says(nx, ny, poisson):
    lat = auxetic_sheet(nx, ny, poisson=poisson)
    x0, edges = lat.frame.positions, lat.frame.edges
    c0 = float(x0[(nx + 1) * (ny + 1), 0] - (1 - nx))  # first module's +node, relative to its centre
    usable = lat.strain_range
    assert usable.lower.strain < 0 < usable.upper.strain
    shortest = np.linalg.norm(x0[edges[:, 0]] - x0[edges[:, 1]], axis=1).min()
    assert abs(usable.shortest_bar - shortest) <= 1e-12
    reference_crossings = crossings(x0, edges)
    rank_gap = sigma_ratio(x0, edges)
    for eps in np.linspace(usable.lower.strain, usable.upper.strain, 25):
        x = sheet_at(nx, ny, 1.0, 1.0, c0, eps)
        assert x is not None
        assert relative_bar_error([x], edges, x0) <= 1e-12
        assert closest_unjoined(x, edges) >= PROXIMITY_FRACTION * shortest * (1 - 1e-9)
        assert crossings(x, edges) == reference_crossings
    for end, sign in ((usable.upper, 1), (usable.lower, -1)):
        at = sheet_at(nx, ny, 1.0, 1.0, c0, end.strain)
        beyond = sheet_at(nx, ny, 1.0, 1.0, c0, end.strain + sign * 1e-4)
        assert end.detail
        if end.reason == "node_proximity":
            assert abs(closest_unjoined(at, edges) / shortest - PROXIMITY_FRACTION) <= 1e-9
            assert closest_unjoined(beyond, edges) < PROXIMITY_FRACTION * shortest
        elif end.reason == "singular_point":
            # The symmetric curve folds or flattens there: no configuration beyond, or C's
            # smallest singular value vanishes at the end.
            assert beyond is None or sigma_ratio(at, edges) <= 1e-4 * rank_gap
        else:
            assert end.reason == "bar_crossing"
            assert crossings(beyond, edges) != reference_crossings


def test_sheet_range_does_not_depend_on_the_number_of_cells_past_the_neighbours():
    """Every event is between a module and its neighbours: from 3 × 3 cells on, the range is the
    same (the 50 × 50 sheet is verified at its ends here by the k-d-tree-free brute force on a
    5 × 5 corner of it, which is congruent)."""
    ranges = {n: auxetic_sheet(n, n, poisson=-0.5).strain_range for n in (3, 5, 50)}
    for n in (5, 50):
        assert abs(ranges[n].upper.strain - ranges[3].upper.strain) <= 1e-12
        assert abs(ranges[n].lower.strain - ranges[3].lower.strain) <= 1e-12


def test_sheet_strain_outside_the_range_is_refused():
    usable = auxetic_sheet(4, 4, poisson=-0.5).strain_range
    from zeromode.solver.errors import DomainError

    with pytest.raises(DomainError) as err:
        auxetic_sheet(4, 4, poisson=-0.5, strain=usable.upper.strain + 1e-3)
    assert err.value.code == "strain_out_of_range"
    assert f"{usable.upper.strain:+.6g}" in err.value.message


def test_chain_range_states_and_proximity():
    """A 3D chain's states lie in its range, keep every bar, and keep every pair of nodes without
    a bar apart (brute force)."""
    lat = auxetic_chain_3d(3, poisson=-0.5)
    x0, edges = lat.frame.positions, lat.frame.edges
    shortest = np.linalg.norm(x0[edges[:, 0]] - x0[edges[:, 1]], axis=1).min()
    assert lat.strain_range.lower.strain < 0 < lat.strain_range.upper.strain
    sets = {k: np.asarray(v) for k, v in lat.boundary.items()}
    for state, nu, eps in lat.states.values():
        assert relative_bar_error([state], edges, x0) <= 1e-9
        assert closest_unjoined(state, edges) >= PROXIMITY_FRACTION * shortest
        ex, ey = boundary_strains(x0, state, sets, finite=True)
        assert abs(ex - eps) <= 1e-12 and abs(nu + ey / ex) <= 1e-12


# --------------------------------------------------------------------------- over HTTP
def test_auxetic_response_reports_the_range_and_refuses_outside(client):
    body = client.post("/v1/design/auxetic", json={"cells": [4, 4], "poisson_ratio": -0.5}).json()
    usable = body["report"]["strain_range"]
    assert usable["lower"]["reason"] in ("node_proximity", "singular_point", "bar_crossing")
    assert usable["upper"]["strain"] > 0 > usable["lower"]["strain"]
    for state in body["states"]:
        assert usable["lower"]["strain"] <= state["strain"] <= usable["upper"]["strain"]
    assert body["report"]["min_node_distance"] >= usable["proximity_fraction"] * (1 - 1e-9)
    refused = client.post("/v1/design/auxetic", json={"cells": [4, 4], "poisson_ratio": -0.5, "strain": 0.1})
    assert refused.status_code == 422
    detail = refused.json()["detail"]
    assert detail["code"] == "strain_out_of_range"
    assert f"{usable['upper']['strain']:+.6g}" in detail["message"]


def test_motion_on_a_lattice_reports_strain_and_secant_ratio(client):
    design = client.post("/v1/design/auxetic", json={"cells": [3, 3], "poisson_ratio": -0.5}).json()
    frame = design["frame"]
    response = client.post(
        "/v1/motion",
        json={
            "frame": {"positions": frame["positions"], "edges": frame["edges"], "dim": 2},
            "amplitude": 0.05,
            "boundary": design["report"]["boundary"],
        },
    )
    assert response.status_code == 200, response.text
    body = response.json()
    x0 = np.array(frame["positions"])
    sets = {k: np.asarray(v) for k, v in design["report"]["boundary"].items()}
    assert len(body["strains"]) == len(body["path"]) == len(body["poisson_ratio"])
    for x, strain, nu in zip(body["path"], body["strains"], body["poisson_ratio"]):
        ex, ey = boundary_strains(x0, np.array(x), sets, finite=True)
        assert abs(strain[0] - ex) <= 1e-12 and abs(strain[1] - ey) <= 1e-12
        assert (nu is None) == (ex == 0)
        if nu is not None and abs(ex) > 1e-3:
            assert abs(nu + ey / ex) <= 1e-9
            assert nu < 0  # auxetic over this small amplitude
    bad = client.post(
        "/v1/motion",
        json={"frame": {"positions": frame["positions"], "edges": frame["edges"], "dim": 2}, "boundary": {"left": [0]}},
    )
    assert bad.status_code == 422 and bad.json()["detail"]["code"] == "invalid_boundary"
