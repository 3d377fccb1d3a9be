"""Auxetic lattices from coupled modules (paper, "Combining Network Modes for Potential
Applications", Fig. 5c–d, and Supplementary "Combining Networks with Repeating Modules").

Derivations used here, independent of the code under test:

* Module (Fig. S1a): corners (±w, ±h) moving with u = diag(1, β)·x, an unspecified node at (c, 0)
  moving with (p, q) and joined to all four corners.  The bars to (w, ±h) give
  (w − c)(w − p) + h(βh ∓ q) = 0, so q = 0; those to (−w, ±h) give (w + c)(w + p) = −βh²;
  subtracting, p = −c, and then c² = w² + βh².  So the nodes sit at (±c, 0) and move with
  (∓c, 0), and a module exists iff w² + βh² > 0, i.e. iff ν = −β < w²/h².
* Counts: an n_x × n_y sheet has N = (n_x+1)(n_y+1) + 2n_x n_y nodes and 8n_x n_y bars, so
  2N − N_B = 2(n_x+1)(n_y+1) − 4n_x n_y.  With exactly 3 + 1 zero modes, Maxwell's count
  N_D + s = zero modes gives s = 2(n_x − 1)(n_y − 1) self-stresses (the redundant constraints of
  the symmetric tiling).
* Poisson ratio (the documented definition): ν = −ε_y/ε_x, ε the relative rate of change of
  the distance between the mean positions of the opposite boundary corner rows — the boundary
  sets are found here from the geometry (corner rows are at y = (2j − n_y)h, module nodes at
  odd multiples of h).
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles import pyrigi_adapter
from oracles.designs import check_frame_modes
from oracles.motion import boundary_strains, relative_bar_error
from oracles.rigidity import (
    compatibility_matrix,
    mode_residual,
    normalised,
    numerical_rank,
    rigid_generators,
    zero_modes_and_stresses,
)

from zeromode.solver.applications.lattice import auxetic_chain_3d, auxetic_sheet
from zeromode.solver.errors import DomainError, InvalidInput

SIZES = [(nx, ny) for nx in range(1, 7) for ny in range(1, 7)]


def boundary_sets(positions: np.ndarray, corner_rows: np.ndarray) -> dict[str, np.ndarray]:
    """Left/right/bottom/top boundary nodes among the nodes whose y is a corner row."""
    corners = np.flatnonzero(np.isclose(positions[:, 1][:, None], corner_rows[None]).any(axis=1))
    x, y = positions[corners, 0], positions[corners, 1]
    return {
        "left": corners[np.isclose(x, x.min())],
        "right": corners[np.isclose(x, x.max())],
        "bottom": corners[np.isclose(y, y.min())],
        "top": corners[np.isclose(y, y.max())],
    }


def sheet_boundary(lat, ny: int, h: float) -> dict:
    return boundary_sets(lat.frame.positions, (2 * np.arange(ny + 1) - ny) * h)


# --------------------------------------------------------------------------- 2D sheets
@pytest.mark.parametrize("poisson", [-1.0, -0.5])
def test_sheets_one_nontrivial_mode_for_every_size(poisson):
    """1×1 … 6×6: exactly 4 zero modes (3 rigid + 1), s = 2(n_x − 1)(n_y − 1), C·mode = 0, the
    module nodes where the derivation puts them, and ν of the mode = the requested value."""
    w, h = 1.0, 1.0
    c = np.sqrt(w**2 - poisson * h**2)
    for nx, ny in SIZES:
        lat = auxetic_sheet(nx, ny, poisson=poisson, cell=(w, h))
        x, edges = lat.frame.positions, lat.frame.edges
        n_corner = (nx + 1) * (ny + 1)
        assert len(x) == n_corner + 2 * nx * ny and len(edges) == 8 * nx * ny
        assert zero_modes_and_stresses(x, edges) == (4, 2 * (nx - 1) * (ny - 1))
        cm = compatibility_matrix(normalised(x), edges)
        assert mode_residual(cm, lat.mode) <= 1e-12
        assert (
            numerical_rank(np.column_stack([rigid_generators(normalised(x)), lat.mode.ravel()]))
            == 4
        )
        # Corners move with diag(1, β)·x; module nodes sit at centre ± (c, 0) and move with
        # diag(1, β)·centre ∓ (c, 0).
        beta = np.array([1.0, -poisson])
        assert np.allclose(lat.mode[:n_corner], x[:n_corner] * beta, atol=1e-12)
        inner = x[n_corner:]
        centres = np.repeat(0.5 * (inner[0::2] + inner[1::2]), 2, axis=0)
        offset = inner - centres
        assert np.allclose(np.abs(offset[:, 0]), c, atol=1e-12) and np.allclose(offset[:, 1], 0)
        assert np.allclose(lat.mode[n_corner:], centres * beta - offset, atol=1e-12)
        sets = sheet_boundary(lat, ny, h)
        assert {k: sorted(v) for k, v in lat.boundary.items()} == {
            k: sorted(v.tolist()) for k, v in sets.items()
        }
        ex, ey = boundary_strains(x, lat.mode, sets, finite=False)
        assert abs(-ey / ex - poisson) <= 1e-9 and abs(lat.poisson_ratio - poisson) <= 1e-9
        assert lat.poisson_ratio < 0


@pytest.mark.parametrize(("nx", "ny"), [(1, 1), (1, 2), (2, 1), (2, 2)])
def test_small_sheets_against_pyrigi(nx, ny):
    lat = auxetic_sheet(nx, ny, poisson=-0.5)
    flexes = pyrigi_adapter.flexes(lat.frame.positions, lat.frame.edges)
    assert (flexes.all.shape[1], flexes.nontrivial.shape[1], flexes.stresses) == (
        4,
        1,
        2 * (nx - 1) * (ny - 1),
    )


def test_large_sheet_20x20():
    lat = auxetic_sheet(20, 20, poisson=-0.5)
    x, edges = lat.frame.positions, lat.frame.edges
    assert zero_modes_and_stresses(x, edges) == (4, 2 * 19 * 19)
    assert mode_residual(compatibility_matrix(normalised(x), edges), lat.mode) <= 1e-12
    sets = sheet_boundary(lat, 20, 1.0)
    ex, ey = boundary_strains(x, lat.mode, sets, finite=False)
    assert abs(-ey / ex + 0.5) <= 1e-9
    assert set(lat.states) == {"expanded", "contracted"}
    for name, (state, _, _) in lat.states.items():
        assert relative_bar_error([state], edges, x) <= 1e-9, name


@pytest.mark.parametrize("poisson", [-2.0, -1.0, -0.5, -0.2])
def test_sheet_finite_states(poisson):
    """Expanded/contracted states keep every bar length (1e-9 relative), stretch along x by the
    requested strain (half the nearer end of the usable range) in the named direction, and
    report the secant ν and ε_x computed here.  (They need not stay auxetic: at ν = −0.2 the
    expanded state's secant ratio is slightly positive.)"""
    for nx, ny in [(1, 1), (3, 2), (6, 6)]:
        usable = auxetic_sheet(nx, ny, poisson=poisson).strain_range
        strain = 0.5 * min(usable.upper.strain, -usable.lower.strain)
        lat = auxetic_sheet(nx, ny, poisson=poisson, strain=strain)
        x, edges = lat.frame.positions, lat.frame.edges
        sets = sheet_boundary(lat, ny, 1.0)
        assert set(lat.states) == {"expanded", "contracted"}
        for name, (state, nu, eps) in lat.states.items():
            assert relative_bar_error([state], edges, x) <= 1e-9
            ex, ey = boundary_strains(x, state, sets, finite=True)
            assert (ex > 0) == (name == "expanded") and abs(abs(ex) - strain) <= 1e-12
            assert abs(nu - (-ey / ex)) <= 1e-12 and abs(eps - ex) <= 1e-12
        assert lat.max_relative_bar_error <= 1e-9


def test_sheet_states_midway_to_a_range_end_past_the_last_scan_step():
    """ν = −57 (found by the REST hypothesis test as a 500): the motion is steep, the contracted
    end (node proximity at ε ≈ −0.0077) lies inside the first scan step, and ε = −0.0039 is
    nearer that end's sample than ε = 0, from which Newton alone missed it. The states still
    keep every bar length and sit at the requested strain."""
    usable = auxetic_sheet(1, 1, poisson=-57.0).strain_range
    strain = 0.00390625
    assert -usable.lower.strain - strain < strain < usable.upper.strain  # nearer the lower end's sample
    lat = auxetic_sheet(1, 1, poisson=-57.0, strain=strain)
    x, edges = lat.frame.positions, lat.frame.edges
    sets = sheet_boundary(lat, 1, 1.0)
    for name, (state, _, _) in lat.states.items():
        assert relative_bar_error([state], edges, x) <= 1e-9, name
        ex, _ = boundary_strains(x, state, sets, finite=True)
        assert abs(abs(ex) - strain) <= 1e-12 and (ex > 0) == (name == "expanded")


def test_sheet_secant_ratio_tends_to_the_linear_one():
    """At small strain the finite states follow the mode: the secant ν → the linear ν."""
    lat = auxetic_sheet(2, 2, poisson=-0.5, strain=1e-6)
    assert set(lat.states) == {"expanded", "contracted"}
    for _, nu, _ in lat.states.values():
        assert abs(nu + 0.5) <= 1e-5


def test_poisson_ratio_invariant_under_sheet_and_cell_size():
    """Every module deforms identically, so ν (linear and secant) does not depend on the number
    of cells; the bar constraints are scale-free, so it does not depend on the cell's scale."""
    reference = auxetic_sheet(1, 1, poisson=-0.7, cell=(1.0, 1.5), strain=0.05)
    ref_secant = {k: v[1] for k, v in reference.states.items()}
    assert set(ref_secant) == {"expanded", "contracted"}
    for nx, ny in [(2, 3), (5, 4)]:
        for scale in (1e-3, 1.0, 1e3):
            lat = auxetic_sheet(nx, ny, poisson=-0.7, cell=(scale, 1.5 * scale), strain=0.05)
            sets = sheet_boundary(lat, ny, 1.5 * scale)
            ex, ey = boundary_strains(lat.frame.positions, lat.mode, sets, finite=False)
            assert abs(-ey / ex + 0.7) <= 1e-9
            assert set(lat.states) == set(ref_secant)
            for name, (state, _, _) in lat.states.items():
                ex, ey = boundary_strains(lat.frame.positions, state, sets, finite=True)
                assert abs(-ey / ex - ref_secant[name]) <= 1e-9


@pytest.mark.parametrize(
    ("cell", "possible", "impossible"), [((1.0, 1.0), 0.9, 1.5), ((1.0, 2.0), 0.2, 0.3)]
)
def test_impossible_ratio_has_no_module(cell, possible, impossible):
    """The module exists iff ν < w²/h² (derivation above): the conic meets the symmetry axis."""
    w, h = cell
    assert possible < w**2 / h**2 <= impossible
    lat = auxetic_sheet(1, 1, poisson=possible, cell=cell)
    assert abs(lat.frame.positions[4, 0] - np.sqrt(w**2 - possible * h**2)) <= 1e-12
    for nu in (impossible, w**2 / h**2):
        with pytest.raises(DomainError) as err:
            auxetic_sheet(2, 2, poisson=nu, cell=cell)
        assert err.value.code == "no_solution" and err.value.message


@pytest.mark.parametrize(("nx", "ny"), [(0, 1), (1, 0), (-1, 3), (51, 50)])
def test_sheet_bad_sizes(nx, ny):
    with pytest.raises(InvalidInput) as err:
        auxetic_sheet(nx, ny)
    assert err.value.code == "invalid_size"


# --------------------------------------------------------------------------- 3D chains
@pytest.fixture(scope="module")
def chains():
    return {n: auxetic_chain_3d(n, poisson=-0.5) for n in range(1, 5)}


@pytest.mark.parametrize("n", range(1, 5))
def test_3d_chain(chains, n):
    """n blocks: 3N − N_B = 7, one nontrivial mode, no self-stress (C built here; PyRigi for
    n ≤ 2); ν = −0.5 from the mode with boundary ports found here; finite states keep the bars."""
    lat = chains[n]
    x, edges = lat.frame.positions, lat.frame.edges
    assert 3 * len(x) - len(edges) == 7
    check_frame_modes(x, edges, lat.mode[None], use_pyrigi=n <= 2)
    # Ports: the specified nodes in the plane z = 0; apexes are off it.
    spec = np.asarray(lat.frame.specified)
    ports = spec[np.isclose(x[spec, 2], 0.0)]
    assert len(ports) == 2 * (n + 1)
    px, py = x[ports, 0], x[ports, 1]
    sets = {
        "left": ports[np.isclose(px, px.min())],
        "right": ports[np.isclose(px, px.max())],
        "bottom": ports[np.isclose(py, py.min())],
        "top": ports[np.isclose(py, py.max())],
    }
    assert {k: set(v) for k, v in lat.boundary.items()} == {
        k: set(v.tolist()) for k, v in sets.items()
    }
    ex, ey = boundary_strains(x, lat.mode, sets, finite=False)
    assert abs(-ey / ex + 0.5) <= 1e-9 and abs(lat.poisson_ratio + 0.5) <= 1e-9
    assert set(lat.states) == {"expanded", "contracted"}
    for name, (state, nu, eps) in lat.states.items():
        assert relative_bar_error([state], edges, x) <= 1e-9, name
        ex, ey = boundary_strains(x, state, sets, finite=True)
        assert (ex > 0) == (name == "expanded")
        assert abs(nu - (-ey / ex)) <= 1e-12 and abs(eps - ex) <= 1e-12
        assert lat.strain_range.lower.strain - 1e-12 <= ex <= lat.strain_range.upper.strain + 1e-12


def test_3d_chain_boundary_lists_are_sets(chains):
    for n, lat in chains.items():
        assert set(lat.boundary) == {"left", "right", "bottom", "top"}
        for name, nodes in lat.boundary.items():
            assert len(nodes) == len(set(nodes)), (n, name, nodes)


# --------------------------------------------------------------------------- the pipeline over HTTP
def test_auxetic_refine_and_certify_in_one_request(client):
    """A 1 × 1 sheet refined (corners driven along the mode) and certified in one request: the
    refined path keeps every bar (recomputed here), the refined mode is a zero mode of the
    refined frame (C built here) and its linear ν is what the boundary means give here."""
    response = client.post(
        "/v1/design/auxetic",
        json={"cells": [1, 1], "poisson_ratio": -0.5, "refine": {"amplitude": 0.05}, "certify": True},
    )
    assert response.status_code == 200, response.text
    report = response.json()["report"]
    refinement = report["refinement"]
    assert refinement["status"] == "ok" and refinement["epsilon_after"] <= 1e-6
    assert refinement["iterations"] >= 0
    x = np.array(refinement["frame"]["positions"])
    edges = np.array(refinement["frame"]["edges"])
    assert relative_bar_error(np.array(refinement["path"]), edges, x) <= 1e-6
    mode = np.array(refinement["modes"][0])
    assert mode_residual(compatibility_matrix(normalised(x), edges), mode) <= 1e-9
    sets = {k: np.asarray(v) for k, v in report["boundary"].items()}
    ex, ey = boundary_strains(x, mode, sets, finite=False)
    assert abs(report["refined_poisson_ratio"] + ey / ex) <= 1e-9
    assert report["certificate"]["self_stress"] is not None
    assert {"design", "refine", "certify", "total"} <= set(report["timings_ms"])


def test_auxetic_refinement_with_more_equations_than_unknowns_is_refused(client):
    response = client.post("/v1/design/auxetic", json={"cells": [3, 3], "poisson_ratio": -0.5, "refine": {}})
    assert response.status_code == 422
    detail = response.json()["detail"]
    assert detail["code"] == "too_few_unknowns" and "576 bar equations" in detail["message"]
