"""Motion of a tiled frame through one cell (solver/motion/periodic.py) against the frame's own route.

Checks go through independent routes: bar lengths and boundary strains recomputed from the
returned positions (oracles.motion), rigid alignment by oracles.motion.rigid_distance, the
tiling re-derived here from the positions, and the frame's own continuation (every node, no
periodicity assumed) as the reference path.
"""

import time

import numpy as np
import pytest
from fastapi.testclient import TestClient
from oracles.motion import boundary_strains, relative_bar_error, rigid_distance
from oracles.wire import frame_body

from zeromode.service.rest.app import create_app
from zeromode.solver import DomainError, Frame
from zeromode.solver.applications.lattice import auxetic_sheet
from zeromode.solver.motion.finite_motion import trace_motion
from zeromode.solver.motion.periodic import (
    PeriodicCell,
    find_tiling,
    tiled_motion,
    trace_motion_through_cell,
    trace_periodic_motion,
)
from zeromode.solver.progress import progress_scope


@pytest.fixture(scope="module")
def sheet4():
    return auxetic_sheet(4, 4, poisson=-0.5)


@pytest.fixture(scope="module")
def sheet10():
    return auxetic_sheet(10, 10, poisson=-0.5)


def test_the_tiling_found_places_every_node_as_a_translate_of_one_cell(sheet4):
    frame = sheet4.frame
    tiling, lattice = find_tiling(frame)
    # Periods of the 4 × 4 sheet: the module's width and height (2w = 2h = 2) along the axes.
    assert sorted(np.abs(lattice).sum(axis=1).tolist()) == [2.0, 2.0]
    assert np.abs(np.abs(lattice) @ np.ones(2) - 2.0).max() == 0.0
    node, cells = tiling[:, 0], tiling[:, 1:]
    assert node.max() + 1 == 3  # a corner and the two module nodes
    origin = frame.positions - cells @ lattice
    for i in range(3):
        assert np.ptp(origin[node == i], axis=0).max() <= 1e-12
    # A frame that is no tiling: random points joined to their neighbours.
    rng = np.random.default_rng(3)
    x = rng.uniform(size=(60, 2))
    edges = [(i, j) for i in range(60) for j in range(i + 1, 60) if np.linalg.norm(x[i] - x[j]) < 0.2]
    assert find_tiling(Frame.build(x, np.array(edges))) is None


def test_periodic_route_and_full_route_agree_on_a_4x4_sheet(sheet4):
    frame = sheet4.frame
    tiling, lattice = find_tiling(frame)
    cell = PeriodicCell.from_frame(frame, tiling, lattice)
    # Forward along the designed mode, short of the collision near parameter 0.079.
    rates = _cell_rates_of(sheet4, tiling, cell)
    periodic = tiled_motion(frame, tiling, cell, trace_periodic_motion(cell, tiling, rates, amplitude=0.06))
    full = trace_motion(frame, mode=sheet4.mode, amplitude=0.06)
    assert periodic.method == "periodic" and full.method == "dense"
    assert not periodic.singularities and not full.singularities
    assert relative_bar_error(periodic.positions, frame.edges, frame.positions) <= 1e-9
    # The parameter is the frame's pseudo-arclength in both: the ends coincide.
    assert periodic.parameter[[0, -1]] == pytest.approx([-0.06, 0.06], abs=1e-12)
    for k in (0, -1):
        assert rigid_distance(periodic.positions[k], full.positions[k]) <= 1e-8 * np.ptp(frame.positions)
    # Boundary strains (recomputed here) along both paths lie on one curve ε_y(ε_x).
    strains = [
        np.array([boundary_strains(frame.positions, x, sheet4.boundary, finite=True) for x in p.positions])
        for p in (periodic, full)
    ]
    assert np.all(np.diff(strains[0][:, 0]) > 0)
    assert np.interp(strains[1][:, 0], *strains[0].T) == pytest.approx(strains[1][:, 1], abs=1e-4)


def _cell_rates_of(lattice, tiling, cell):
    """The cell's nontrivial mode rates signed along the lattice's designed mode, from the
    mode's own values at one node of each cell orbit: the designed mode is affine per cell."""
    n_c = len(cell.positions)
    cells, node = tiling[:, 1:], tiling[:, 0]
    # Least squares for (node rates, lattice rates) with mode_n = v_{i(n)} + c_n·Λ.
    t = np.zeros((len(tiling), n_c + cells.shape[1]))
    t[np.arange(len(tiling)), node] = 1.0
    t[:, n_c:] = cells
    return np.linalg.lstsq(t, lattice.mode, rcond=None)[0]


def test_through_cell_follows_a_large_sheet_like_its_own_continuation(sheet10):
    frame = sheet10.frame  # 642 degrees of freedom: above the dense route
    periodic = trace_motion_through_cell(frame, mode=sheet10.mode, amplitude=0.05, max_step=0.02)
    full = trace_motion(frame, mode=sheet10.mode, amplitude=0.05, max_step=0.02)
    assert periodic.method == "periodic" and full.method == "sparse"
    assert relative_bar_error(periodic.positions, frame.edges, frame.positions) <= 1e-9
    for k in (0, -1):
        assert periodic.parameter[k] == pytest.approx(full.parameter[k], abs=1e-12)
        assert np.abs(periodic.positions[k] - full.positions[k]).max() <= 1e-8 * np.ptp(frame.positions)
    # Without a mode both take the frame's mode with its largest entry positive.
    default = trace_motion_through_cell(frame, amplitude=0.02, direction="forward")
    assert default.method == "periodic"
    expected = trace_motion(frame, amplitude=0.02, direction="forward")
    assert np.abs(default.positions[-1] - expected.positions[-1]).max() <= 1e-8 * np.ptp(frame.positions)
    # The opposite mode follows the same curve the other way.
    flipped = trace_motion_through_cell(frame, mode=-sheet10.mode, amplitude=0.05, direction="forward")
    assert flipped.method == "periodic"
    assert np.abs(flipped.positions[-1] - periodic.positions[0]).max() <= 1e-8 * np.ptp(frame.positions)


def test_through_cell_stops_at_the_end_of_the_strain_range(sheet10):
    frame, boundary = sheet10.frame, sheet10.boundary
    lo, hi = sheet10.strain_range.lower.strain, sheet10.strain_range.upper.strain

    def stop(x, sign):
        ex = boundary_strains(frame.positions, x, boundary, finite=True)[0]
        return ex >= hi or ex <= lo

    path = trace_motion_through_cell(frame, sheet10.mode, amplitude=5.0, stop=stop, max_steps=20000)
    assert path.method == "periodic" and not path.singularities
    ends = [boundary_strains(frame.positions, path.positions[k], boundary, finite=True)[0] for k in (0, -1)]
    # The last step is shortened to where the strain leaves the range (not up to a step past it).
    assert ends[0] <= lo and ends[0] == pytest.approx(lo, abs=1e-6)
    assert ends[1] >= hi and ends[1] == pytest.approx(hi, abs=1e-6)
    assert relative_bar_error(path.positions, frame.edges, frame.positions) <= 1e-9


def test_a_frame_that_fails_the_check_is_followed_by_its_own_continuation(sheet10):
    frame = sheet10.frame
    # Without a bar at its corner node the sheet has two nontrivial modes: a tiling is still
    # found, the check on the frame refuses it, and the frame's own continuation answers as
    # trace_motion does.
    corner_bar = np.flatnonzero((frame.edges == 0).any(axis=1))[0]
    cut = Frame.build(frame.positions, np.delete(frame.edges, corner_bar, axis=0))
    assert find_tiling(cut) is not None
    with pytest.raises(DomainError) as direct:
        trace_motion(cut)
    with pytest.raises(DomainError) as through:
        trace_motion_through_cell(cut)
    assert through.value.code == direct.value.code == "ambiguous_mode"
    path = trace_motion_through_cell(cut, mode=sheet10.mode, amplitude=0.02)
    assert path.method == "sparse"
    assert relative_bar_error(path.positions, cut.edges, cut.positions) <= 1e-9


def test_a_50x50_sheet_over_rest_goes_through_its_cell():
    sheet = auxetic_sheet(50, 50, poisson=-0.5)
    frame = sheet.frame
    reports = []
    with progress_scope(lambda fraction, message: reports.append((time.perf_counter(), fraction))):
        path = trace_motion_through_cell(frame, sheet.mode, amplitude=0.03)
    assert path.method == "periodic"
    times, fractions = np.array(reports).T
    assert np.all(np.diff(fractions) >= 0) and fractions[-1] >= 0.95
    # Progress moves at least every second or every 5 % (2 s here: CI machines are loaded).
    assert np.all((np.diff(times) <= 2.0) | (np.diff(fractions) <= 0.05))
    body = {"frame": frame_body(frame), "mode": sheet.mode.tolist(), "amplitude": 0.03, "boundary": sheet.boundary}
    r = TestClient(create_app()).post("/v1/motion", json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["method"] == "periodic" and out["status"] == "ok"
    positions = np.array(out["path"])
    assert relative_bar_error(positions, frame.edges, frame.positions) <= 1e-9
    assert out["parameter"][0] == pytest.approx(-0.03) and out["parameter"][-1] == pytest.approx(0.03)
    strains = np.array([boundary_strains(frame.positions, x, sheet.boundary, finite=True) for x in positions])
    assert np.array(out["strains"]) == pytest.approx(strains, abs=1e-12)
    assert np.abs(positions - path.positions).max() <= 1e-9 * np.ptp(frame.positions)
