"""Every expensive quantity is refused before work starts, in ≤ 50 ms (issue #18), against a live
`zeromode serve` (offloading on, its engine running): for every endpoint and for jobs, requests
past a size limit (nodes, bars, the dense SVD's size, NLP unknowns, LMI size, relays, lattice
cells and blocks, tolerance and refinement sizes, specified nodes, samples, sweep points) are
answered 422 with the limit's code, the median CPU time the server spends on five of them
within 50 ms (its round trips are measured too, by the benchmark).

The probes (benchmarks/bench_adversarial.py ``size_probes``) run on a service whose node and bar
limits are 1 100 and 3 100, so a frame past them is a small body: what is timed is the refusal,
not the upload of megabytes.
"""

from __future__ import annotations

import pytest
from test_offload import running_service

from benchmarks.bench_adversarial import REFUSAL_MS, SMALL_LIMITS, refusal_times, size_probes


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory):
    tmp = tmp_path_factory.mktemp("refusals")
    env = {"ZEROMODE_DATABASE_URL": f"sqlite:///{tmp}/jobs.sqlite3", "ZEROMODE_OFFLOAD": "true",
           "ZEROMODE_DASK_WORKERS": "1", **SMALL_LIMITS}
    with running_service(tmp, env, "refusals") as (address, _, proc):
        yield address, proc.pid


def test_every_endpoint_refuses_what_is_too_large_within_50_ms(served):
    url, server_pid = served
    probes = size_probes()
    assert {p.path for p in probes} >= {
        "/v1/analyze", "/v1/motion", "/v1/refine", "/v1/certify", "/v1/design", "/v1/design/auxetic",
        "/v1/design/allosteric", "/v1/design/allosteric/network", "/v1/design/two-configuration",
        "/v1/solution-space", "/v1/plot", "/v1/export", "/v1/sweeps", "/v1/jobs", "/v1/map", "/v1/design/sequential",
    }
    rows = refusal_times(url, probes, server_pid=server_pid)
    wrong = [r for r in rows if not r["ok"]]
    assert not wrong, wrong
    # The server's CPU time, not the round trip: a busy machine stretches the wall clock of any
    # request, not the work a refusal does.
    slow = [r for r in rows if r["median_cpu_ms"] > REFUSAL_MS]
    assert not slow, slow
