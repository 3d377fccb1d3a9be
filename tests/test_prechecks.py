"""zeromode/operations/prechecks.py: what each job endpoint refuses up front, decided without its computation.

For every job endpoint a table of bad requests, each with the code written here from the
request's own defect (a sheet colliding at rest, a refinement with more bar equations than
unknowns counted here, ...): the endpoint called directly (the real app) answers 422 with that
code, and ``precheck`` on the validated request raises the same code, in milliseconds. Good
requests pass ``precheck``, and the cheap ones are answered 200 by the endpoint.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import pytest
from oracles.frames import K4_PLANE, SQUARE, TRIANGLE
from test_allostery import request_body, sites

from zeromode.operations.prechecks import precheck
from zeromode.service.jobs.tasks import RUNNABLE
from zeromode.solver.errors import DomainError

# Worst case for one check (issue #18: a refusal in ≤ 50 ms); an auxetic sheet's `strain` is
# decided on its usable range, one module's scan per sheet (kept), which costs more.
WORST_MS = 50.0
STRAIN_SCAN_MS = 1000.0
# Typical points of a sweep (median over the tables).
TYPICAL_MS = 5.0

OUTWARD_FOUR = {
    "dim": 2,
    "positions": [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]],
    "motions": [[[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]],
    "options": {"seed": 0, "n_unspecified": 4},
}
SHEAR = [[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [-1.0, 0.0]]
TWIST = [[0.0, 1.0], [0.0, -1.0], [0.0, 1.0], [0.0, -1.0]]


def path_frame(n: int, specified: int = 2) -> dict:
    """n nodes on a zig-zag, bars between neighbours, the first ``specified`` specified."""
    x = np.column_stack([np.arange(n, dtype=float), 0.3 * (np.arange(n) % 2)])
    return {"dim": 2, "positions": x.tolist(), "edges": [[i, i + 1] for i in range(n - 1)], "specified": list(range(specified))}


def complete_frame(n: int, specified: int) -> dict:
    """K_n on points of a circle: n(n − 1)/2 bars."""
    t = 2 * np.pi * np.arange(n) / n
    x = np.column_stack([np.cos(t), np.sin(t) * 0.7])
    edges = [[i, j] for i in range(n) for j in range(i + 1, n)]
    return {"dim": 2, "positions": x.tolist(), "edges": edges, "specified": list(range(specified))}


def many_nodes(n: int) -> dict:
    """n nodes, no bars (a size only)."""
    x = np.column_stack([np.arange(n) % 200, np.arange(n) // 200]).astype(float)
    return {"dim": 2, "positions": x.tolist(), "edges": []}


def nlp_counts(n: int, n_unspecified: int, n_bars: int, K: int, d: int = 2) -> tuple[int, int]:
    """The refinement's bar equations K·N_B and unknowns 2·N_U·d + (K − 1)·N·d (counted here)."""
    return K * n_bars, 2 * n_unspecified * d + (K - 1) * n * d


x_src, u_src, x_tgt, u_tgt = sites(2, 3.0)

# (endpoint, request, code): each request's defect is named beside it.
# The tristable triangle of docs/multistable.md (the named example).
TRISTABLE = {
    "dim": 2,
    "conformations": [[[0.0, 0.0], [1.0, 0.0], [0.3, 0.8]], [[0.0, 0.0], [1.0, 0.0], [0.45, 1.0]],
                      [[0.0, 0.0], [1.0, 0.0], [0.65, 1.15]]],
}

SOLITON = [{"kind": "fixed_point", "d": 1.2, "slope": 1.8}, {"kind": "fixed_point", "d": 1.8, "slope": 0.4}]
# The two-triangle module (solver.sequential.module_map.two_triangle_module): 5 nodes, 6 bars.
MODULE = {"frame": {"dim": 2, "positions": [[-1, 0], [1, 0], [-0.8, 1], [0.8, 1], [0.15, 0.45]],
                    "edges": [[0, 2], [0, 4], [2, 4], [1, 3], [1, 4], [3, 4]]},
          "input_pair": [0, 1], "output_pair": [2, 3]}
FIXED = [{"kind": "fixed_point", "d": 1.5, "slope": -0.5}]


def strip_module(n: int, dim: int = 2) -> dict:
    """A module of n nodes on a zig-zag strip, the pairs its ends (a size, a dimension only)."""
    positions = [[float(i), float(i % 2)] + [0.0] * (dim - 2) for i in range(n)]
    edges = [[i, i + 1] for i in range(n - 1)] + [[i, i + 2] for i in range(n - 3)]
    return {"frame": {"dim": dim, "positions": positions, "edges": edges}, "input_pair": [0, n - 1],
            "output_pair": [1, n - 2]}


BAD = [
    # /v1/map: the pairs (Module.build), the size.
    ("/v1/map", {**MODULE, "input_pair": [0, 2]}, "invalid_pair"),  # a bar
    ("/v1/map", {**MODULE, "input_pair": [1, 1]}, "invalid_pair"),
    ("/v1/map", {**MODULE, "output_pair": [1, 0]}, "invalid_pair"),  # the input pair again
    ("/v1/map", {**MODULE, "input_pair": [0, 5]}, "invalid_pair"),  # no node 5
    ("/v1/map", {"frame": many_nodes(201), "input_pair": [0, 1], "output_pair": [2, 3]}, "too_expensive"),  # 402 > 400
    # /v1/design/sequential: the features, the start, the NLP's ladder, a chain's module.
    ("/v1/design/sequential", {"features": [{"kind": "period_two", "d1": 1.5, "d2": 1.5}]}, "invalid_feature"),
    ("/v1/design/sequential", {"features": [{"kind": "fixed_point", "d": 9.0, "slope": 0.5}]},
     "feature_out_of_reach"),  # 9 > 2 · 3 RMS radii (0.83) of the two-triangle module
    ("/v1/design/sequential", {"features": FIXED, "start": strip_module(17)}, "too_expensive"),  # 17 > 16 nodes
    ("/v1/design/sequential", {"features": [{"kind": "range", "source": [0.1, 150.0], "target": [0.1, 150.0]}],
                               "reach": 100.0}, "too_expensive"),  # 150 / (0.05 · 0.83) ≫ 200 configurations
    ("/v1/design/sequential", {"features": FIXED, "start": strip_module(6, dim=3), "chain": {}}, "invalid_dim"),
    ("/v1/design/sequential", {"features": FIXED, "chain": {},  # 7 bars on 5 nodes: 7 + 1 + 3 ≠ 10
                               "start": {**MODULE, "frame": {**MODULE["frame"], "edges": [*MODULE["frame"]["edges"], [0, 3]]}}},
     "invalid_module"),
    ("/v1/design/sequential", {"features": FIXED, "chain": {}, "start": {**MODULE, "output_pair": [1, 2]}}, "invalid_pair"),
    # The soliton: both a chain and a soliton; features that are not one unstable and one stable
    # fixed point; more copies than the wall reaches, ln(0.6/(2ε·1.2))/ln 1.8 ≈ 59 < 64 − 2.
    ("/v1/design/sequential", {"features": SOLITON, "chain": {}, "soliton": {}}, "invalid_soliton"),
    ("/v1/design/sequential", {"features": FIXED, "soliton": {}}, "invalid_soliton"),
    ("/v1/design/sequential", {"features": SOLITON, "soliton": {"n_modules": 64}}, "soliton_out_of_reach"),
    # /v1/analyze: the frame itself.
    ("/v1/analyze", {"frame": {**TRIANGLE, "edges": [[0, 1], [1, 7]]}}, "edge_out_of_range"),
    ("/v1/analyze", {"frame": {**TRIANGLE, "edges": [[0, 1], [1, 0]]}}, "duplicate_edge"),
    ("/v1/analyze", {"frame": {**TRIANGLE, "edges": [[1, 1]]}}, "self_loop"),
    ("/v1/analyze", {"frame": {"dim": 2, "positions": [[0, 0], [0, 0]], "edges": [[0, 1]]}}, "zero_length_bar"),
    # /v1/design: the targets and options.
    ("/v1/design", {**OUTWARD_FOUR, "positions": [[1.0, 1.0], [1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]}, "degenerate_specified"),
    ("/v1/design", {**OUTWARD_FOUR, "motions": [[[1.0, 0.0]] * 4]}, "rigid_target"),  # a translation
    ("/v1/design", {**OUTWARD_FOUR, "motions": [[[1.0, 1.0]] * 3]}, "invalid_shape"),  # 3 rows for 4 nodes
    (
        "/v1/design",
        {**OUTWARD_FOUR, "motions": [OUTWARD_FOUR["motions"][0], SHEAR], "options": {"refine": {}}},
        "invalid_options",  # refinement follows one motion
    ),
    (
        "/v1/design",
        {**OUTWARD_FOUR, "motions": [OUTWARD_FOUR["motions"][0], SHEAR, TWIST], "options": {"n_unspecified": 2}},
        "invalid_options",  # 3 motions in 2D go to hierarchical groups, whose count is theirs
    ),
    # /v1/design/auxetic.
    ("/v1/design/auxetic", {"cells": [0, 40]}, "invalid_size"),
    ("/v1/design/auxetic", {"dim": 3, "cells": [4, 4]}, "invalid_size"),
    ("/v1/design/auxetic", {"dim": 3, "cells": [65]}, "invalid_size"),
    ("/v1/design/auxetic", {"cells": [2, 2], "cell": [1.0, 1.0, 1.0]}, "invalid_cell"),
    ("/v1/design/auxetic", {"cells": [2, 2], "cell": [-1.0, 1.0]}, "invalid_cell"),
    ("/v1/design/auxetic", {"cells": [1, 1], "cell": [1e-185, 1e-185]}, "out_of_range"),  # squares underflow
    # ν = 0: each module's axis node sits where its neighbour's does (c² = w² + βh² = w²).
    ("/v1/design/auxetic", {"cells": [4, 4], "poisson_ratio": 0.0}, "no_solution"),
    ("/v1/design/auxetic", {"cells": [4, 1], "poisson_ratio": 0.0}, "no_solution"),
    # ν = 2 with w = h: w² + βh² < 0, the module's conic misses its axis.
    ("/v1/design/auxetic", {"cells": [4, 4], "poisson_ratio": 2.0}, "no_solution"),
    # ν = 0 in 3D: the ports move by diag(1, 0, 0)·x, the two left ports by the same vector.
    ("/v1/design/auxetic", {"dim": 3, "cells": [3], "poisson_ratio": 0.0}, "coupling_failed"),
    ("/v1/design/auxetic", {"dim": 3, "cells": [2], "finite_strain": {"strain_range": [-0.1, 0.1]}}, "invalid_options"),
    ("/v1/design/auxetic", {"cells": [2, 2], "finite_strain": {"strain_range": [0.1, 0.2]}}, "invalid_strain_range"),
    # 4 × 4 sheet, corners specified: 8·128 bar equations against 2·32·2 + 7·57·2 unknowns.
    ("/v1/design/auxetic", {"cells": [4, 4], "poisson_ratio": -0.5, "refine": {}}, "too_few_unknowns"),
    # 8 × 8 sheet: 2·(81 + 128) = 418 degrees of freedom, tolerances stop at 400.
    ("/v1/design/auxetic", {"cells": [8, 8], "poisson_ratio": -0.5, "tolerance": {}}, "too_expensive"),
    # A chain of 20 blocks (13 nodes each, 2 merged per coupling): 3·(260 − 38) = 666 > 400.
    ("/v1/design/auxetic", {"dim": 3, "cells": [20], "poisson_ratio": -0.5, "tolerance": {}}, "too_expensive"),
    # /v1/design/allosteric.
    ("/v1/design/allosteric", request_body(x_src, u_src, x_tgt, u_tgt, relay_spacing=1e-3, relay_growth=1.0), "too_expensive"),  # ~3000 relays
    ("/v1/design/allosteric", request_body(x_src, u_src, x_src + 1e-12, u_tgt), "overlapping_sites"),
    ("/v1/design/allosteric", request_body(x_src, np.ones_like(u_src), x_tgt, u_tgt), "rigid_source"),
    ("/v1/design/allosteric", request_body(x_src, u_src, x_tgt, np.zeros_like(u_tgt)), "rigid_target"),
    ("/v1/design/allosteric", request_body(x_src, u_src[:-1], x_tgt, u_tgt), "invalid_shape"),
    # /v1/design/multistable: the conformations.
    ("/v1/design/multistable", {**TRISTABLE, "conformations": [TRISTABLE["conformations"][0]] * 2}, "rigid_target"),
    ("/v1/design/multistable", {"dim": 2, "conformations": [[[0, 0], [1, 0]], [[0, 0], [2, 0]]]}, "too_few_nodes"),
    ("/v1/design/multistable", {"dim": 2, "conformations": [[[i, i * i % 7] for i in range(17)],
                                                             [[i, i * i % 5] for i in range(17)]]}, "too_expensive"),
    ("/v1/design/multistable", {"dim": 2, "conformations": TRISTABLE["conformations"][:2], "options": {"bifurcation": 0}},
     "invalid_bifurcation"),  # a branch point needs two minima beside it: three conformations
    # /v1/motion.
    ("/v1/motion", {"frame": SQUARE, "boundary": {"left": [0], "right": [1], "bottom": [0], "top": [9]}}, "invalid_boundary"),
    ("/v1/motion", {"frame": {**SQUARE, "positions": [[0.0, 0.0], [1e160, 0.0], [1e160, 1e160], [0.0, 1e160]]}}, "out_of_range"),
    ("/v1/motion", {"frame": SQUARE, "mode": [[1.0, 0.0]] * 3}, "invalid_shape"),  # 3 rows for 4 nodes
    ("/v1/motion", {"frame": many_nodes(30_001)}, "too_expensive"),  # 60 002 > 60 000 degrees of freedom
    # /v1/refine.
    ("/v1/refine", {"frame": {**SQUARE, "specified": [0]}, "motion": [[1.0, 0.0]]}, "too_few_specified"),
    ("/v1/refine", {"frame": {**SQUARE, "specified": [0, 1, 2, 3]}, "motion": SHEAR}, "nothing_to_refine"),
    ("/v1/refine", {"frame": {**SQUARE, "specified": [0, 1]}, "motion": [[0.0, 0.0], [0.0, 0.0]]}, "invalid_motion"),
    ("/v1/refine", {"frame": {**SQUARE, "specified": [0, 1]}, "targets": [[0.0, 0.0], [1.0, 0.0]]}, "invalid_motion"),
    ("/v1/refine", {"frame": {**SQUARE, "specified": [0, 1]}, "motion": [[1.0, 0.0]]}, "invalid_shape"),
    ("/v1/refine", {"frame": complete_frame(6, 2), "motion": [[1.0, 0.0], [-1.0, 0.0]]}, "too_few_unknowns"),
    (
        "/v1/refine",
        {"frame": path_frame(160), "motion": [[1.0, 0.0], [-1.0, 0.0]], "options": {"K": 64}},
        "too_expensive",  # 2·158·2 + 63·160·2 = 20 792 unknowns > 20 000
    ),
    # /v1/certify.
    ("/v1/certify", {"frame": TRIANGLE, "modes": [[[1.0, 0.0], [0.0, 0.0]]]}, "invalid_modes"),  # 2 rows for 3 nodes
    ("/v1/certify", {"frame": TRIANGLE, "modes": [[[1.0, 0.0], [0.0, 0.0], [0.0, 0.0]]]}, "invalid_modes"),  # stretches a bar
    ("/v1/certify", {"frame": SQUARE, "modes": [[[1.0, 0.0]] * 4]}, "invalid_modes"),  # a translation
    ("/v1/certify", {"frame": many_nodes(30_001), "options": {"stiffness": False}}, "too_expensive"),
    ("/v1/certify", {"frame": many_nodes(1_300)}, "too_expensive"),  # p = 2600 − 3 > 2500 with stiffness
]

GOOD = [
    ("/v1/analyze", {"frame": K4_PLANE}, True),
    ("/v1/design", OUTWARD_FOUR, True),
    ("/v1/design/auxetic", {"cells": [2, 2], "poisson_ratio": -0.5}, True),
    ("/v1/design/auxetic", {"cells": [2, 2], "poisson_ratio": -0.5, "strain": 0.05}, True),
    ("/v1/design/auxetic", {"cells": [1, 4], "poisson_ratio": 0.0}, True),  # one column: no neighbour to meet
    ("/v1/design/auxetic", {"cells": [3, 3], "poisson_ratio": -0.5, "tolerance": {}, "certify": True}, False),
    ("/v1/design/auxetic", {"dim": 3, "cells": [2], "poisson_ratio": -0.5}, False),
    ("/v1/design/auxetic", {"dim": 3, "cells": [2], "poisson_ratio": -0.5, "tolerance": {}, "refine": {}}, False),
    ("/v1/design/allosteric", request_body(x_src, u_src, x_tgt, u_tgt), False),
    ("/v1/design/multistable", TRISTABLE, False),  # answered in test_api_multistable
    ("/v1/map", {**MODULE, "at": [1.8]}, True),
    ("/v1/design/sequential", {"features": FIXED, "chain": {"n_modules": 4}}, False),  # test_jobs_sequential
    ("/v1/motion", {"frame": SQUARE, "boundary": {"left": [0, 3], "right": [1, 2], "bottom": [0, 1], "top": [2, 3]}}, True),
    ("/v1/refine", {"frame": {**SQUARE, "specified": [0, 1]}, "motion": [[0.0, 1.0], [0.0, -1.0]]}, False),
    ("/v1/certify", {"frame": K4_PLANE}, True),
]


def model_of(endpoint: str, body: dict):
    return RUNNABLE[endpoint].request_model.model_validate(body)


def timed(endpoint: str, body) -> tuple[float, Exception | None]:
    """Best of three times (ms) of precheck, CPU time of this thread (which runs it: a loaded
    machine does not inflate it), and what it raised."""
    times, raised = [], None
    for _ in range(3):
        t0 = time.thread_time()
        try:
            precheck(endpoint, body)
        except Exception as exc:  # noqa: BLE001 — compared below
            raised = exc
        times.append(1e3 * (time.thread_time() - t0))
    return min(times), raised


def test_the_tables_cover_every_job_endpoint():
    assert {e for e, _, _ in BAD} == set(RUNNABLE) == {e for e, _, _ in GOOD}


@pytest.mark.parametrize(("endpoint", "body", "code"), BAD, ids=[f"{e}:{c}" for e, _, c in BAD])
def test_a_bad_request_is_refused_up_front_with_the_endpoints_code(client, endpoint, body, code):
    direct = client.post(endpoint, json=body)
    assert direct.status_code == 422, direct.text[:300]
    assert direct.json()["detail"]["code"] == code, direct.text[:300]
    ms, raised = timed(endpoint, model_of(endpoint, body))
    assert isinstance(raised, DomainError), raised
    assert raised.code == code, raised.message
    assert ms <= WORST_MS, f"{ms:.1f} ms"


@pytest.mark.parametrize(("endpoint", "body", "answered"), GOOD, ids=[e for e, _, _ in GOOD])
def test_a_good_request_passes(client, endpoint, body, answered):
    ms, raised = timed(endpoint, model_of(endpoint, body))
    assert raised is None, raised
    limit = STRAIN_SCAN_MS if "strain" in body else WORST_MS
    assert ms <= limit, f"{ms:.1f} ms"
    if answered:
        response = client.post(endpoint, json=body)
        assert response.status_code == 200, response.text[:300]


@pytest.mark.parametrize(
    ("poisson", "strain", "inside"),
    # The usable ranges measured by the full scan (report.strain_range of the answer): checked
    # against the endpoint's own answer below, so only the side of the range matters here.
    [(-1.0, 0.8, False), (-0.5, 0.3, False), (-1.0, 0.12, True), (0.5, 0.1, True), (-5.0, 0.1, False)],
)
def test_an_auxetic_strain_is_decided_as_the_full_range_decides_it(client, poisson, strain, inside):
    """The precheck's decision agrees with the endpoint's answer: its report.strain_range when
    no strain is asked, its refusal when one is outside; a second point on the same sheet costs
    no scan."""
    body = {"cells": [3, 3], "poisson_ratio": poisson, "strain": strain}
    ms, raised = timed("/v1/design/auxetic", model_of("/v1/design/auxetic", body))
    assert ms <= STRAIN_SCAN_MS, f"{ms:.1f} ms"
    free = client.post("/v1/design/auxetic", json={**body, "strain": None}).json()["report"]["strain_range"]
    assert (free["lower"]["strain"] <= -strain and strain <= free["upper"]["strain"]) == inside
    assert (raised is None) == inside, raised
    if not inside:
        assert raised.code == "strain_out_of_range"
        direct = client.post("/v1/design/auxetic", json=body)
        assert direct.json()["detail"]["code"] == "strain_out_of_range"
    again, _ = timed("/v1/design/auxetic", model_of("/v1/design/auxetic", {**body, "strain": strain / 2, "seed": 1}))
    assert again <= WORST_MS, f"{again:.1f} ms"


def test_a_sweeps_points_are_checked_in_milliseconds():
    """A sweep's typical points (poisson ratio × cells × seed, designs, motions): median ≤
    TYPICAL_MS, none over WORST_MS."""
    points = [
        ("/v1/design/auxetic", {"cells": [n, n], "poisson_ratio": nu, "seed": s})
        for nu in (-0.3, -0.5, -0.8, -1.2) for n in (2, 4, 8, 16) for s in range(3)
    ] + [("/v1/design", {**OUTWARD_FOUR, "options": {"seed": s}}) for s in range(12)] + [
        ("/v1/motion", {"frame": SQUARE, "amplitude": a}) for a in (0.1, 0.2, 0.3, 0.4)
    ]
    times = []
    for endpoint, body in points:
        ms, raised = timed(endpoint, model_of(endpoint, body))
        assert raised is None, (body, raised)
        times.append(ms)
    assert statistics.median(times) <= TYPICAL_MS, f"median {statistics.median(times):.2f} ms"
    assert max(times) <= WORST_MS, f"worst {max(times):.1f} ms"
