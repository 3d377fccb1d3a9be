"""The usable strain range of sheets one, two and three modules wide, against a continuation of
the whole tiled sheet (tests/oracles/sheet_range.py: _Curve's predictor-corrector with numpy's
SVD, every node pair and (node, bar) pair of the sheet examined by brute force).

The range is scanned on one module and the copies around it (strain_range.module_range); a sheet
narrower than that patch lacks some of those copies, and a pair between copies it lacks (a node
of the neighbour on the left and a bar of the neighbour on the right of a two-column sheet) is no
event of it.  Issue #42: [2, 3] at ν = −0.3 ended at −0.244958 ("passes through the bar …") where
the sheet itself first collides at −0.323388.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.motion import boundary_strains, relative_bar_error
from oracles.sheet_range import SheetEvents, first_event

from zeromode.solver.applications.finite_strain import finite_strain_sheet
from zeromode.solver.applications.lattice import auxetic_sheet, sheet_module_for
from zeromode.solver.applications.sheet_module import sheet_edges, sheet_positions, trammel_module
from zeromode.solver.applications.strain_range import Patch
from zeromode.solver.errors import DomainError

# Events located by the scan to STRAIN_XTOL and by the oracle's bisection: they agree to
# round-off (measured ≤ 3e-14); a singular end is located by bisection on Newton's success
# (FOLD_XTOL) and by the oracle's shrinking steps, far less precisely.
EVENT_ATOL = 1e-9
SINGULAR_ATOL = 1e-5

# 1 × n, 2 × n and 3 × n (and n × 1 …) at a few Poisson ratios, among them those where the
# module's patch watched pairs the sheet does not have (ν = −0.3, −0.5, −1.1 on two columns).
CASES = [
    (1, 1, -1.0), (1, 2, -0.3), (1, 3, 0.3), (1, 4, -1.1),
    (2, 1, -0.5), (2, 2, -1.1), (2, 2, -0.3), (2, 3, -0.3), (2, 4, 0.3),
    (3, 1, -0.3), (3, 2, -0.5), (3, 3, -1.0), (4, 2, -0.3),
]


@pytest.mark.parametrize(("nx", "ny", "poisson"), CASES)
def test_range_is_the_whole_sheet_continuation(nx, ny, poisson):
    lat = auxetic_sheet(nx, ny, poisson=poisson)
    usable = lat.strain_range
    for end, sign in ((usable.lower, -1), (usable.upper, 1)):
        strain, reason = first_event(
            lat.frame.positions, lat.frame.edges, lat.boundary, sign, usable.proximity_fraction
        )
        if reason == "search_limit":
            assert end.reason == "search_limit" and sign * end.strain <= sign * strain
            continue
        assert end.reason == reason, (end, strain, reason)
        tol = SINGULAR_ATOL if reason == "singular_point" else EVENT_ATOL
        assert abs(end.strain - strain) <= tol, (end, strain)


@pytest.mark.parametrize(
    ("nx", "ny", "poisson", "strain", "lower"),
    # The two cases, at the lower ends the whole-sheet continuation finds.
    [(2, 2, -1.0, 0.16, -0.234236), (2, 3, -0.3, 0.04, -0.323388), (2, 2, -0.3, 0.04, -0.323388)],
)
def test_narrow_sheets_are_served_inside_the_true_range(nx, ny, poisson, strain, lower):
    lat = auxetic_sheet(nx, ny, poisson=poisson, strain=strain)
    assert abs(lat.strain_range.lower.strain - lower) <= 5e-7
    x0, edges = lat.frame.positions, lat.frame.edges
    apart = SheetEvents(x0, edges, lat.strain_range.proximity_fraction)
    sets = {k: np.asarray(v) for k, v in lat.boundary.items()}
    for name, sign in (("expanded", 1), ("contracted", -1)):
        x, nu, eps = lat.states[name]
        assert relative_bar_error([x], edges, x0) <= 1e-12
        ex, ey = boundary_strains(x0, x, sets, finite=True)
        assert abs(ex - sign * strain) <= 1e-12 and abs(eps - ex) <= 1e-12 and abs(nu + ey / ex) <= 1e-12
        assert apart.gap(x) >= 0  # no two nodes without a bar closer than the fraction of ℓ_min
    # A strain past the true end is still refused, naming the range.
    beyond = abs(lower) + 1e-3
    with pytest.raises(DomainError) as err:
        auxetic_sheet(nx, ny, poisson=poisson, strain=beyond)
    assert err.value.code == "strain_out_of_range" and f"{lower:+.6g}" in err.value.message


def pair_signatures(x, pairs, node_bar):
    """Translation-invariant signatures of node pairs (their distance) and of (node, q, r)
    pairs (the node's distance from the bar's line, from its midpoint along it, in units of its
    length, and its squared length; the same whichever end is named first): what the range scan
    watches of each."""
    distances = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)[:, None]
    p, q, r = node_bar.T
    along, rel = x[r] - x[q], x[p] - x[q]
    norm2 = np.sum(along * along, axis=1)
    area = (along[:, 0] * rel[:, 1] - along[:, 1] * rel[:, 0]) / norm2
    t = np.sum(rel * along, axis=1) / norm2
    return distances, np.column_stack([np.abs(area), np.abs(t - 0.5), norm2])


def same_sets(a, b, tol=1e-9) -> bool:
    """Every row of a is within tol of a row of b and vice versa."""
    gap = np.max(np.abs(a[:, None, :] - b[None, :, :]), axis=2)
    return bool(gap.min(axis=1).max() <= tol and gap.min(axis=0).max() <= tol)


@pytest.mark.parametrize("family", ["two_node", "trammel"])
@pytest.mark.parametrize(("nx", "ny"), [(1, 1), (1, 3), (2, 2), (2, 3), (3, 2), (3, 3)])
def test_watched_pairs_are_the_sheets_own(nx, ny, family):
    """With copies up to n − 1 modules away the patch watches, up to translation, exactly the
    node pairs without a bar and the (node, bar) pairs of the tiled sheet (brute force on the
    frame): none the sheet lacks, none it has left out.  A generic cell (and ratio, or trammel
    nodes) keeps different pairs' signatures apart; the patch of a wide sheet has pairs this
    one lacks."""
    if family == "two_node":
        poisson, cell = -0.37, (1.0, 0.7)
        module, _ = sheet_module_for(nx, ny, poisson, cell)
        frame = auxetic_sheet(nx, ny, poisson=poisson, cell=cell).frame
        x, edges = frame.positions, frame.edges
    else:  # the finite-strain family (axis nodes inside the cell, joined across)
        module = trammel_module(1.0, 0.7, 0.55, 0.45)
        x, edges = sheet_positions(module, nx, ny, module.reference), sheet_edges(module, nx, ny)
    n = len(x)
    joined = np.eye(n, dtype=bool)
    joined[edges[:, 0], edges[:, 1]] = joined[edges[:, 1], edges[:, 0]] = True
    p, e = np.meshgrid(np.arange(n), np.arange(len(edges)), indexing="ij")
    p, e = p.ravel(), e.ravel()
    off = (p != edges[e, 0]) & (p != edges[e, 1])
    sheet = pair_signatures(x, np.argwhere(np.triu(~joined)), np.column_stack([p[off], edges[e[off]]]))

    def watched(cells):
        patch = Patch.of(module, (nx - 1, ny - 1), cells)
        xp = patch.positions(module, module.reference)
        b = patch.node_bar
        return pair_signatures(xp, patch.pairs, np.column_stack([b[:, 0], patch.bars[b[:, 1]]]))

    own = watched((nx, ny))
    assert same_sets(own[0], sheet[0]) and same_sets(own[1], sheet[1])
    if max(nx, ny) > 1:  # the test tells the difference: a wide sheet's patch has more
        wide = watched((9, 9))
        assert not (same_sets(wide[0], sheet[0]) and same_sets(wide[1], sheet[1]))


@pytest.mark.parametrize(("nx", "ny", "poisson"), [(2, 2, -0.5), (2, 3, -0.8), (1, 2, -0.5)])
def test_finite_strain_sheet_range_is_the_whole_sheet_continuation(nx, ny, poisson):
    """The sheet chosen for its secant ratio (a trammel, or a refined module) reports the range of
    its own n_x × n_y frame."""
    lat = finite_strain_sheet(nx, ny, poisson=poisson, strain_range=(-0.1, 0.1), tolerance=0.02, cell=(1.0, 1.0)).lattice
    usable = lat.strain_range
    for end, sign in ((usable.lower, -1), (usable.upper, 1)):
        strain, reason = first_event(lat.frame.positions, lat.frame.edges, lat.boundary, sign, usable.proximity_fraction)
        assert end.reason == reason and abs(end.strain - strain) <= EVENT_ATOL, (end, strain, reason)
