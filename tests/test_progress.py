"""Progress of the long computations (solver/progress.py), recorded as a job would see it.

Each case runs a real computation inside ``progress_scope`` with a callback that stamps every
report with the process's CPU time, then checks what a user polling the job sees: the fractions never
go back, stay in [0, 1] and end at ≥ 0.95, and between two successive reports either little
time passed or little work was claimed — so a job never looks stuck for long and never jumps
by much without having reported in between.

The promise is a report at least every 1.0 s or every 5 % of the work; the assertion allows
2 s of CPU time for the time side (a numba compile in another thread can land between two
reports), and it counts CPU time, not the wall clock, so other processes sharing the two cores
cannot stretch a silence: the property tested is that the stage reports at all, not the
machine's speed.
"""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from oracles.frames import SQUARE_CORNERS

from benchmarks.allostery_tasks import make_task
from benchmarks.lattices import LATTICES
from zeromode.service.jobs.tasks import execute
from zeromode.service.wire.settings import Settings
from zeromode.solver.applications.lattice import auxetic_sheet
from zeromode.solver.applications.network_allostery import tune_network
from zeromode.solver.certificates.prestress import certify
from zeromode.solver.construction.two_configuration import design_two_configurations
from zeromode.solver.pipeline import RefineStage, ToleranceStage, auxetic_pipeline, design_pipeline
from zeromode.solver.progress import (
    progress_heartbeat,
    progress_scope,
    progress_stage,
    report_detail,
    report_progress,
)

# The promise (seconds, fraction) and the time side as asserted under shared-CPU load.
PROMISED_GAP_S = 1.0
ASSERTED_GAP_S = 2.0
FRACTION_GAP = 0.05


def recorded(run, job: bool = False):
    """``run()`` inside a progress scope (a job: ``run(callback)``, which opens its own): its
    result and the reports [(t, fraction, message)], the first stamped at the start (fraction
    0) and t in seconds of the process's CPU time from it: the silence asserted is over work
    done, so other processes on a shared machine do not stretch it (2.5 s of wall clock between
    two reports was seen once at load 13)."""
    t0 = time.process_time()
    reports = [(0.0, 0.0, "start")]

    def callback(fraction: float, message: str) -> None:
        reports.append((time.process_time() - t0, fraction, message))

    if job:
        return run(callback), reports
    with progress_scope(callback):
        result = run()
    return result, reports


def check_reports(reports) -> None:
    """Monotone, in [0, 1], ending ≥ 0.95, and no silent stretch that is both long and large."""
    t, f = np.array([r[0] for r in reports]), np.array([r[1] for r in reports])
    assert np.all((f >= 0) & (f <= 1)), reports
    back = np.flatnonzero(np.diff(f) < 0)
    assert back.size == 0, [reports[i : i + 2] for i in back[:5]]
    assert f[-1] >= 0.95, reports[-5:]
    # A long silence is allowed only over little work: little of the fraction claimed and
    # little of the run's time (the fraction's weights are estimates; the clock is the work).
    dt, df = np.diff(t), np.diff(f)
    stuck = np.flatnonzero((dt > ASSERTED_GAP_S) & ((df > FRACTION_GAP) | (dt > FRACTION_GAP * t[-1])))
    assert stuck.size == 0, [(reports[i], reports[i + 1]) for i in stuck[:5]]


def test_stages_map_inner_fractions_onto_their_share():
    """progress_stage against the affine map computed here: a nested stage's f lands at
    lo + f·(hi − lo) of its parent's interval, itself mapped into the scope's."""
    seen = []
    scope = progress_scope(lambda f, m: seen.append((f, m)))
    with scope, progress_stage(0.2, 0.6, "outer"), progress_stage(0.5, 1.0, "inner"):
        report_progress(0.5, "half")
    fractions = [f for f, _ in seen]
    # outer [0.2, 0.6]; inner [0.2 + 0.4·0.5, 0.2 + 0.4·1] = [0.4, 0.6]; half → 0.5.
    assert fractions == pytest.approx([0.2, 0.4, 0.5, 0.6, 0.6])
    assert seen[2][1] == "outer: inner: half"
    # Outside a scope the stages and reports go nowhere.
    with progress_stage(0.0, 1.0, "alone"):
        report_progress(0.5, "nobody listens")
    assert len(seen) == 5


def test_detail_reports_go_only_into_a_stage_opened_for_them():
    seen = []
    with progress_scope(lambda f, m: seen.append(f)):
        report_detail(0.5)  # the scope itself: a loop's share, not opened for a building block
        with progress_stage(0.0, 0.5, detail=True):
            report_detail(0.5)
            with progress_stage(0.5, 1.0):  # nested: not the building block's own
                report_detail(0.9)
    assert seen == pytest.approx([0.0, 0.25, 0.25, 0.5, 0.5])


def test_heartbeat_reports_the_clock_while_an_opaque_call_runs():
    """1 − exp(−t/τ) of the stage at each beat, t measured here; nothing once the block ends."""
    seen = []
    t0 = time.perf_counter()
    with progress_scope(lambda f, m: seen.append((time.perf_counter() - t0, f))), progress_stage(0.5, 1.0):
        with progress_heartbeat(1.0, "sleeping", interval_s=0.1):
            time.sleep(0.65)
        ended = len(seen)
        time.sleep(0.25)
    beats = seen[1:ended]
    # About 6 beats; fewer when the shared CPU delays the thread. Then the stage's end, no beat.
    assert 2 <= len(beats) <= 7 and len(seen) == ended + 1
    for t, f in beats:
        # The heartbeat's clock starts a little after this test's (entering the blocks; 50 ms
        # allows for preemption) and reads a little before the report is received.
        assert 0.5 + 0.5 * (1 - np.exp(-(t - 0.05))) <= f <= 0.5 + 0.5 * (1 - np.exp(-t)) + 1e-12


def test_design_fig3c_with_refinement_and_certificates():
    """Paper Fig. 3c: the outward square, four unspecified nodes, refined and certified."""
    result, reports = recorded(
        lambda: design_pipeline(
            SQUARE_CORNERS, [SQUARE_CORNERS], dim=2, n_unspecified=4,
            refine_stage=RefineStage(), certify_stage=True,
        )
    )
    assert result.refinement is not None and result.certificate is not None
    check_reports(reports)


def test_refinement_as_a_job():
    """/v1/refine of the Fig. 3c design, as a job runs it (one IPOPT solve, no retry)."""
    frame = design_pipeline(SQUARE_CORNERS, [SQUARE_CORNERS], dim=2, n_unspecified=4).design.frame
    request = {
        "frame": {"dim": 2, "positions": frame.positions.tolist(), "edges": frame.edges.tolist(), "specified": [0, 1, 2, 3]},
        "motion": SQUARE_CORNERS,
    }
    (status, body), reports = recorded(lambda callback: job("/v1/refine", request, callback), job=True)
    assert status == "done", body
    check_reports(reports)


def test_multi_motion_designs_and_two_configuration_design():
    """Placement rounds of a 3D design for two motions (a second and more in its first round),
    hierarchical groups for three motions in 2D (M > d), and a design between two
    configurations followed by the motion traced between them."""
    rng = np.random.default_rng([3, 8, 0])
    x, u = rng.standard_normal((8, 3)), rng.standard_normal((2, 8, 3))
    rng = np.random.default_rng([2, 5, 0])
    x3, u3 = rng.standard_normal((5, 2)), rng.standard_normal((3, 5, 2))
    rng = np.random.default_rng(1)
    x2 = rng.standard_normal((6, 2))
    y2 = x2 + 0.3 * rng.standard_normal((6, 2))
    for run in (
        lambda: design_pipeline(x, list(u), dim=3),
        lambda: design_pipeline(x3, list(u3), dim=2),
        lambda: design_two_configurations(x2, y2),
    ):
        _, reports = recorded(run)
        check_reports(reports)


@pytest.mark.parametrize(
    ("cells", "small"),
    # Past 2 × 2 the refinement is refused (the driven corners leave the bars outnumbering what
    # the unspecified nodes can satisfy along a path: check_problem_size) and so are the
    # tolerances (past tolerance.MAX_DOF), as for a request.
    [((2, 2), True), ((8, 8), False), ((20, 20), False)],
)
def test_auxetic_sheet(cells, small):
    """An auxetic sheet with every stage its size allows."""
    stages = {"certify_stage": True}
    if small:
        stages.update(refine_stage=RefineStage(), tolerance_stage=ToleranceStage())
    result, reports = recorded(lambda: auxetic_pipeline(2, cells, poisson=-0.5, **stages))
    assert result.certificate is not None
    assert (result.refinement is not None) == (result.tolerance is not None) == small
    check_reports(reports)


def test_auxetic_chain_and_finite_strain_sheet():
    """A 3D chain of 16 blocks (its range by continuation) and a sheet holding ν over ±10 %
    (the module family searched, ranges scanned, the tiled sheet verified)."""
    for run in (
        lambda: auxetic_pipeline(3, (16,), poisson=-0.5),
        lambda: auxetic_pipeline(2, (8, 8), poisson=-0.5, finite_strain=(-0.1, 0.1, 0.05)),
    ):
        result, reports = recorded(run)
        assert result.lattice.poisson_ratio == pytest.approx(-0.5, rel=1e-6)
        check_reports(reports)


def test_allosteric_design_across_forty_site_radii_with_tolerances_as_a_job():
    """/v1/design/allosteric with its tolerances, as a job runs it: the design, then the
    tolerances' Monte Carlo, in one monotone fraction."""
    rng = np.random.default_rng([2, 0])
    x_src, x_tgt = rng.standard_normal((3, 2)), rng.standard_normal((3, 2))
    u_src, u_tgt = rng.standard_normal((3, 2)), rng.standard_normal((3, 2))
    x_tgt[:, 0] += 40.0
    request = {
        "dim": 2,
        "source": {"positions": x_src.tolist(), "motion": u_src.tolist()},
        "target": {"positions": x_tgt.tolist(), "motion": u_tgt.tolist()},
        "options": {"tolerance": {}},
    }
    (status, body), reports = recorded(lambda callback: job("/v1/design/allosteric", request, callback), job=True)
    assert status == "done", body
    assert body["report"]["tolerance"] is not None
    check_reports(reports)


@pytest.mark.parametrize("n", [40, 400])
def test_allostery_in_a_given_network(n):
    """The pruning peers' random network of n nodes tuned to a strain ratio of −2."""
    task = make_task(n, 0, -2.0)
    result, reports = recorded(
        lambda: tune_network(task.frame, task.source_pair, task.target_pair, strain_ratio=-2.0)
    )
    assert result.target_error <= 1e-9
    check_reports(reports)


def test_certify_a_sheet_with_its_optimal_margin():
    lattice = auxetic_sheet(3, 3, poisson=-0.5)
    result, reports = recorded(lambda: certify(lattice.frame, [lattice.mode]))
    assert result.rigidity_margin.optimal is not None
    check_reports(reports)


def job(endpoint: str, request: dict, callback):
    """``request`` run as a job runs it (service.jobs.tasks.execute), reporting to ``callback``: its
    status and answer."""
    status, data = execute("progress-test", endpoint, request, Settings().model_dump_json(), callback)
    return status, json.loads(data) if status == "done" else data


def test_analysis_of_ten_thousand_nodes_as_a_job():
    frame = LATTICES["kagome"](10_000)
    request = {
        "frame": {"dim": frame.dim, "positions": frame.positions.tolist(), "edges": frame.edges.tolist()},
        "options": {"bases": False},
    }
    (status, body), reports = recorded(lambda callback: job("/v1/analyze", request, callback), job=True)
    assert status == "done", body
    check_reports(reports)
