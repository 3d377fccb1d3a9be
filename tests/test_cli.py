"""Every ``zeromode`` subcommand run as its own process, as a user types it, on a real example;
each output checked through a route that shares nothing with the command's code: counts against
the SVD of a compatibility matrix built in tests/oracles from its definition, designed frames
against that matrix's null space, exports re-read by meshio, networkx and pyarrow, ``serve``
answering on a loopback port, ``job`` and ``sweep`` against that live service.

Missing optional packages are made truly unimportable in a child process (a sitecustomize on
PYTHONPATH whose meta path finder refuses them), never mocked: the CLI, the library and the
service must each say what to install before any work starts.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import resource
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import meshio
import networkx as nx
import numpy as np
import pyarrow.parquet as pq
import pytest
from client.conftest import loopback_socket, wait_for_health
from oracles.designs import check_frame_modes
from oracles.rigidity import COUNT_FIELDS, compatibility_matrix, normalised, reference_counts

ZEROMODE = str(Path(sys.executable).with_name("zeromode"))  # the console script pip installed
# Subcommands this file runs; `zeromode --help` must list exactly these (a new one needs a test).
# `motion` runs as a subprocess in tests/client/test_motion_target_live.py
# (test_cli_motion_command_drives_the_crank, against the four-bar's closed form).
TESTED = {"serve", "analyze", "example", "plot", "job", "sweep", "design", "export", "motion"}
# `zeromode --help` CPU time (parent and children of the process), the floor.
HELP_CPU_S = 0.3
# A first `zeromode serve` in a new environment compiles numba kernels (cold cache): generous,
# the test fails at once if the server dies instead.
STARTUP_S = 300.0
# A designed mode is a zero mode up to round-off: ‖C u‖ ≤ MODE_RTOL·‖C‖‖u‖ (normalised frame).
MODE_RTOL = 1e-9
INSTALL_TABLES = "pip install 'zeromode[tables]'"

# A square with one diagonal missing twice over: 4 nodes, 4 bars, one nontrivial mode (the shear);
# with a diagonal, rigid; with both diagonals, one self-stress.
SQUARE = {"dim": 2, "positions": [[0, 0], [1, 0], [1, 1], [0, 1]], "edges": [[0, 1], [1, 2], [2, 3], [3, 0]]}
EDGE_SETS = [SQUARE["edges"], [*SQUARE["edges"], [0, 2]], [*SQUARE["edges"], [0, 2], [1, 3]]]


def zeromode(*args: str, env: dict[str, str] | None = None, stdin: str | None = None,
             timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run([ZEROMODE, *args], input=stdin, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})}, check=False)


def ok(run: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    assert run.returncode == 0, run.stderr
    return run


def write(path: Path, doc: dict) -> str:
    path.write_text(json.dumps(doc))
    return str(path)


def oracle_counts(frame: dict) -> dict[str, int]:
    return reference_counts(np.array(frame["positions"], float), np.array(frame["edges"], int).reshape(-1, 2))


def assert_zero_modes(frame: dict, modes) -> None:
    """Each mode (N×d) is in the null space of C built from the definition (tests/oracles)."""
    c = compatibility_matrix(normalised(np.array(frame["positions"], float)), frame["edges"])
    norm = np.linalg.norm(c, 2)
    for mode in modes:
        u = np.ravel(mode)
        assert np.linalg.norm(c @ u) <= MODE_RTOL * norm * np.linalg.norm(u)


# The numerical stack and the service's frameworks: none may load for the parser.
HEAVY_IMPORTS = """
import sys
from zeromode.service.cli import build_parser
build_parser()
heavy = ("numpy", "scipy", "pydantic", "fastapi", "zeromode.solver", "zeromode.service.rest.app")
print(sorted(m for m in sys.modules if any(m == h or m.startswith(h + ".") for h in heavy)))
"""


# --- --help, --version --------------------------------------------------------------------------


def test_help_lists_every_subcommand_each_run_here_and_costs_only_the_standard_library():
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    run = ok(zeromode("--help"))
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    listed = set(re.search(r"\{([a-z,]+)\}", run.stdout).group(1).split(","))
    assert listed == TESTED
    assert cpu <= HELP_CPU_S, f"zeromode --help took {cpu:.2f} CPU s"
    # The parser is built without the numerical stack.
    probe = subprocess.run([sys.executable, "-c", HEAVY_IMPORTS], capture_output=True, text=True, check=True)
    assert probe.stdout.strip() == "[]"
    version = ok(zeromode("--version")).stdout.split()
    assert version[0] == "zeromode" and re.fullmatch(r"\d+\.\d+\.\d+.*", version[1])


# --- analyze ------------------------------------------------------------------------------------


@pytest.mark.parametrize("edges", EDGE_SETS, ids=["shear", "rigid", "stressed"])
def test_analyze_prints_the_rest_body_with_the_counts_of_the_svd(tmp_path, client, edges):
    frame = {**SQUARE, "edges": edges}
    body = json.loads(ok(zeromode("analyze", write(tmp_path / "frame.json", frame))).stdout)
    expected = oracle_counts(frame)
    assert {k: body[k] for k in COUNT_FIELDS} == expected
    assert len(body["modes"]) == expected["nontrivial_zero_modes"] and all(np.shape(m) == (4, 2) for m in body["modes"])
    assert len(body["stresses"]) == expected["self_stresses"] and all(len(s) == len(edges) for s in body["stresses"])
    assert_zero_modes(frame, body["modes"])
    # The same body as REST /v1/analyze (timings aside): the keys and every value.
    rest = client.post("/v1/analyze", json={"frame": frame}).json()
    assert set(body) == set(rest)
    assert {k: v for k, v in body.items() if k != "timings_ms"} == {k: v for k, v in rest.items() if k != "timings_ms"}


def test_analyze_reads_a_request_from_stdin_and_prints_a_summary(tmp_path):
    frame = {**SQUARE, "edges": EDGE_SETS[2]}
    request = {"frame": frame, "options": {"method": "dense", "bases": False}}
    body = json.loads(ok(zeromode("analyze", "-", stdin=json.dumps(request))).stdout)
    assert body["method"] == "dense" and body["bases_included"] is False and body["self_stresses"] == 1
    text = ok(zeromode("analyze", write(tmp_path / "f.json", frame), "--pretty")).stdout
    c = oracle_counts(frame)
    assert f"rank C = {c['rank']}" in text
    assert f"zero modes {c['zero_modes']} = {c['rigid_body_modes']} rigid + {c['nontrivial_zero_modes']} nontrivial" in text
    assert f"self-stresses {c['self_stresses']}" in text


def test_analyze_refuses_a_bad_frame_in_one_line_with_exit_code_2(tmp_path):
    run = zeromode("analyze", write(tmp_path / "bad.json", {**SQUARE, "edges": [[0, 0]]}))
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.startswith("error [") and run.stderr.count("\n") == 1 and "Traceback" not in run.stderr


# --- example, design, plot, export ----------------------------------------------------------------


def test_example_lists_the_shipped_examples_and_shows_each_as_a_design_request():
    shipped = sorted(p.stem for p in (Path(__file__).parents[1] / "service" / "wire" / "examples").glob("*.json"))
    listed = ok(zeromode("example", "list")).stdout.splitlines()
    assert sorted(line.split()[0] for line in listed) == shipped
    assert all(len(line.split(maxsplit=1)) == 2 for line in listed)  # each with its description
    request = json.loads(ok(zeromode("example", "show", "outward_2d")).stdout)
    x, u = np.array(request["positions"]), np.array(request["motions"])
    assert request["dim"] == 2 and u.shape[1:] == x.shape
    missing = zeromode("example", "show")
    assert missing.returncode == 2 and "needs a NAME" in missing.stderr


@pytest.fixture(scope="module")
def designed(tmp_path_factory) -> tuple[dict, dict, Path]:
    """`zeromode example show outward_2d | zeromode design -`: (request, response, its file)."""
    request = json.loads(ok(zeromode("example", "show", "outward_2d")).stdout)
    out = tmp_path_factory.mktemp("design") / "design.json"
    ok(zeromode("design", "-", "-o", str(out), stdin=json.dumps(request)))
    return request, json.loads(out.read_text()), out


def test_design_answers_a_frame_whose_zero_modes_are_the_requested_motions(designed):
    request, response, _ = designed
    frame, modes = response["frame"], np.array(response["modes"])
    k = len(request["positions"])
    assert frame["positions"][:k] == request["positions"] and frame["specified"] == list(range(k))
    assert np.array_equal(modes[:, :k], np.array(request["motions"], float))
    check_frame_modes(frame["positions"], frame["edges"], modes, use_pyrigi=False)
    assert_zero_modes(frame, modes)


def test_plot_draws_every_node_and_bar_as_svg_png_and_pdf(tmp_path, designed):
    import xml.etree.ElementTree as ET

    from PIL import Image

    _, response, path = designed
    ok(zeromode("plot", str(path), "-o", str(tmp_path / "d.svg"), "--title", "outward"))
    root = ET.parse(tmp_path / "d.svg").getroot()
    svg = "{http://www.w3.org/2000/svg}"
    classes = [set(e.get("class", "").split()) for e in root.iter()]
    assert sum({"bar"} <= c for c in classes if c) == len(response["frame"]["edges"])
    nodes = [e for e in root.iter(svg + "circle") if "node" in e.get("class", "").split()]
    assert len(nodes) == len(response["frame"]["positions"])
    assert any(e.text == "outward" for e in root.iter(svg + "text"))
    ok(zeromode("plot", str(path), "-o", str(tmp_path / "d.png")))
    with Image.open(tmp_path / "d.png") as png:
        assert png.format == "PNG" and min(png.size) > 100
    ok(zeromode("plot", str(path), "-o", str(tmp_path / "d.pdf")))
    assert (tmp_path / "d.pdf").read_bytes().startswith(b"%PDF")
    refused = zeromode("plot", str(path), "-o", str(tmp_path / "d.gif"))
    assert refused.returncode == 2 and not (tmp_path / "d.gif").exists()


def test_export_writes_files_that_meshio_and_networkx_read_back(tmp_path, designed):
    _, response, path = designed
    positions, edges = np.array(response["frame"]["positions"]), np.array(response["frame"]["edges"])
    ok(zeromode("export", str(path), "-o", str(tmp_path / "d.vtu")))
    mesh = meshio.read(tmp_path / "d.vtu")
    assert np.allclose(mesh.points[:, :2], positions)
    lines = np.concatenate([c.data for c in mesh.cells if c.type == "line"])
    assert {frozenset(e) for e in lines.tolist()} == {frozenset(e) for e in edges.tolist()}
    ok(zeromode("export", str(path), "-o", str(tmp_path / "d.graphml")))
    graph = nx.read_graphml(tmp_path / "d.graphml")
    assert graph.number_of_nodes() == len(positions) and graph.number_of_edges() == len(edges)
    ok(zeromode("export", str(path), "-o", str(tmp_path / "kit"), "--format", "kit_csv", "--mm-per-unit", "100"))
    text = "".join(line for line in (tmp_path / "kit").read_text().splitlines(True) if not line.startswith("#"))
    rows = list(csv.DictReader(io.StringIO(text)))
    assert [(int(r["node_i"]), int(r["node_j"])) for r in rows] == [tuple(e) for e in edges.tolist()]
    lengths = np.linalg.norm(positions[edges[:, 0]] - positions[edges[:, 1]], axis=1)
    assert np.allclose([float(r["length_mm"]) for r in rows], 100 * lengths, atol=1e-5)
    unknown = zeromode("export", str(path), "-o", str(tmp_path / "d.xyz"))
    assert unknown.returncode == 2 and "--format" in unknown.stderr


# --- serve, job, sweep: a live service -------------------------------------------------------------


@contextmanager
def serve(tmp_path: Path, dask_scheduler: str, env: dict[str, str] | None = None) -> Iterator[tuple[str, Path]]:
    """`zeromode serve` on a free loopback port, its jobs on the session's Dask cluster."""
    with loopback_socket() as sock:
        port = sock.getsockname()[1]
    log = tmp_path / "serve.log"
    environment = {**os.environ, "ZEROMODE_DATABASE_URL": f"sqlite:///{tmp_path}/jobs.sqlite3",
                   "ZEROMODE_DASK_SCHEDULER": dask_scheduler, **(env or {})}
    with open(log, "w") as out:
        proc = subprocess.Popen([ZEROMODE, "serve", "--port", str(port)], stdout=out, stderr=subprocess.STDOUT,
                                env=environment)
    url = f"http://127.0.0.1:{port}"
    try:
        wait_for_health(url, lambda: proc.poll() is None, log.read_text, STARTUP_S)
        yield url, log
    finally:
        proc.terminate()
        proc.wait(timeout=30)


@pytest.fixture(scope="module")
def service(tmp_path_factory, dask_scheduler) -> Iterator[tuple[str, Path]]:
    with serve(tmp_path_factory.mktemp("serve"), dask_scheduler) as running:
        yield running


def test_serve_answers_health_and_analysis_on_its_port(service):
    url, log = service
    assert f"zeromode listening on {url}" in log.read_text()
    health = httpx.get(f"{url}/health", timeout=30).json()
    assert health["status"] == "ok" and health["version"] == ok(zeromode("--version")).stdout.split()[1]
    frame = {**SQUARE, "edges": EDGE_SETS[0]}
    body = httpx.post(f"{url}/v1/analyze", json={"frame": frame}, timeout=60).json()
    assert {k: body[k] for k in COUNT_FIELDS} == oracle_counts(frame)


def test_job_runs_on_the_service_and_prints_the_endpoints_answer(tmp_path, service):
    url, _ = service
    frame = {**SQUARE, "edges": EDGE_SETS[2]}
    run = ok(zeromode("job", "analyze", write(tmp_path / "r.json", {"frame": frame}), "--url", url, "--poll", "0.05"))
    body = json.loads(run.stdout)
    assert {k: body[k] for k in COUNT_FIELDS} == oracle_counts(frame)
    assert "100%" in run.stderr  # the progress bar reached its end
    refused = zeromode("job", "analyze", write(tmp_path / "bad.json", {"frame": {**SQUARE, "edges": [[1, 1]]}}),
                       "--url", url)
    assert refused.returncode == 2 and refused.stderr.startswith("error [") and refused.stdout == ""


def sweep_file(tmp_path: Path) -> str:
    """An /v1/analyze sweep over the three edge sets of the square."""
    return write(tmp_path / "grid.json", {"endpoint": "/v1/analyze", "template": {"frame": SQUARE},
                                          "grid": {"frame.edges": EDGE_SETS}})


def check_sweep_points(lines: str) -> None:
    docs = [json.loads(line) for line in lines.splitlines()]
    assert [d["point"] for d in docs] == [0, 1, 2] and all(d["status"] == "done" for d in docs)
    for d, edges in zip(docs, EDGE_SETS, strict=True):
        assert {k: d["result"][k] for k in COUNT_FIELDS} == oracle_counts({**SQUARE, "edges": edges})


def test_sweep_on_the_service_writes_points_and_a_csv_table(tmp_path, service):
    url, _ = service
    table = tmp_path / "t.csv"
    run = ok(zeromode("sweep", sweep_file(tmp_path), "--url", url, "--poll", "0.05", "--table", str(table)))
    check_sweep_points(run.stdout)
    rows = list(csv.DictReader(table.open()))
    assert [int(r["self_stresses"]) for r in rows] == [0, 0, 1]
    assert "3 points: 3 done, 0 not" in run.stderr


def test_sweep_here_on_dask_writes_a_parquet_table(tmp_path, dask_scheduler):
    out, table = tmp_path / "points.ndjson", tmp_path / "t.parquet"
    run = ok(zeromode("sweep", sweep_file(tmp_path), "--scheduler", dask_scheduler, "-o", str(out),
                      "--table", str(table)))
    check_sweep_points(out.read_text())
    rows = pq.read_table(table).to_pylist()
    assert [r["nontrivial_zero_modes"] for r in rows] == [1, 0, 0] and [r["point"] for r in rows] == [0, 1, 2]
    assert "100%" in run.stderr


@pytest.mark.parametrize("spec, code", [
    ({"endpoint": "/v1/analyze", "template": {"frame": SQUARE}, "grid": {"frame.edges": [[[0, 0]]]}}, "invalid_point"),
    ({"template": {"frame": SQUARE}, "grid": {"frame.dim": [2]}}, "invalid_sweep"),
])
def test_a_bad_sweep_is_refused_in_one_line_before_any_cluster_starts(tmp_path, spec, code):
    """The scheduler is unreachable: a refusal that came after connecting would be another error."""
    run = zeromode("sweep", write(tmp_path / "grid.json", spec), "--scheduler", "tcp://127.0.0.1:9")
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.startswith(f"error [{code}]: ") and run.stderr.count("\n") == 1


# --- missing optional packages: a child process in which they cannot be imported ------------------


BLOCKER = '''"""Test-only: the named packages cannot be imported in this process."""
import sys

BLOCKED = {blocked!r}


class _Blocked:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None


sys.meta_path.insert(0, _Blocked())
'''


def without(tmp_path: Path, *packages: str) -> dict[str, str]:
    """The environment of a child process in which ``packages`` cannot be imported."""
    folder = tmp_path / "blocker"
    folder.mkdir(exist_ok=True)
    (folder / "sitecustomize.py").write_text(BLOCKER.format(blocked=set(packages)))
    return {"PYTHONPATH": os.pathsep.join([str(folder), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}


def test_the_blocker_really_blocks(tmp_path):
    run = subprocess.run([sys.executable, "-c", "import pyarrow"], env={**os.environ, **without(tmp_path, "pyarrow")},
                         capture_output=True, text=True, check=False)
    assert run.returncode == 1 and "ModuleNotFoundError" in run.stderr


def test_the_cli_names_the_install_line_before_any_work_without_pyarrow(tmp_path):
    """An unreachable scheduler: had the sweep started, it would fail on the connection."""
    out = tmp_path / "points.ndjson"
    run = zeromode("sweep", sweep_file(tmp_path), "--table", str(tmp_path / "t.parquet"), "-o", str(out),
                   "--scheduler", "tcp://127.0.0.1:9", env=without(tmp_path, "pyarrow"))
    assert run.returncode == 2, run.stderr
    assert run.stderr.count("\n") == 1 and INSTALL_TABLES in run.stderr and "pyarrow" in run.stderr
    assert "Traceback" not in run.stderr and not out.exists()


LIBRARY = """
import json, sys
from zeromode.service.wire.extras import MissingExtra
from zeromode.service.jobs.sweeps import run_sweep, sweep
grid = json.load(open(sys.argv[1]))
args = (grid["endpoint"], grid["template"], grid["grid"])
try:
    sweep(*args, scheduler="tcp://127.0.0.1:9")
except MissingExtra as exc:
    print("refused:", exc)
records = sorted(run_sweep(*args, scheduler=sys.argv[2]), key=lambda r: r["point"])
print(json.dumps([r["result"]["self_stresses"] for r in records]))
"""


def test_the_library_sweep_needs_pandas_and_says_so_before_any_work(tmp_path, dask_scheduler):
    """Without pandas, ``sweep`` raises MissingExtra with the install line before it validates or
    connects (the scheduler is unreachable); ``run_sweep`` needs no optional package."""
    run = subprocess.run([sys.executable, "-c", LIBRARY, sweep_file(tmp_path), dask_scheduler], capture_output=True,
                         text=True, env={**os.environ, **without(tmp_path, "pandas", "pyarrow")}, timeout=300, check=False)
    assert run.returncode == 0, run.stderr
    refused, counts = run.stdout.splitlines()
    assert refused.startswith("refused: sweep()'s DataFrame") and refused.endswith(INSTALL_TABLES)
    assert json.loads(counts) == [0, 0, 1]


def test_the_service_answers_501_with_the_install_line_without_pyarrow(tmp_path, dask_scheduler):
    with serve(tmp_path, dask_scheduler, without(tmp_path, "pyarrow", "pandas")) as (url, _):
        accepted = httpx.post(f"{url}/v1/sweeps", json=json.loads(Path(sweep_file(tmp_path)).read_text()), timeout=60)
        assert accepted.status_code == 202, accepted.text
        sweep_id = accepted.json()["id"]
        deadline = time.monotonic() + 120
        while httpx.get(f"{url}/v1/sweeps/{sweep_id}?limit=0", timeout=30).json()["status"] == "running":
            assert time.monotonic() < deadline, "the sweep did not finish"
            time.sleep(0.05)
        parquet = httpx.get(f"{url}/v1/sweeps/{sweep_id}/results.parquet", timeout=30)
        assert parquet.status_code == 501
        detail = parquet.json()["detail"]
        assert detail["code"] == "parquet_unavailable" and INSTALL_TABLES in detail["message"]
        table = httpx.get(f"{url}/v1/sweeps/{sweep_id}/results.csv", timeout=30)
        assert table.status_code == 200 and len(list(csv.DictReader(io.StringIO(table.text)))) == 3
        assert httpx.get(f"{url}/v1/sweeps/no-such-sweep/results.parquet", timeout=30).status_code == 404


def test_export_says_mp4_needs_ffmpeg_before_designing_anything(tmp_path):
    """PATH without ffmpeg; the document is a design request that would itself be refused
    (invalid_request) had it been designed first."""
    bad_request = write(tmp_path / "request.json", {"dim": 2, "positions": [[0, 0], [1, 0]], "motions": "none"})
    run = zeromode("export", bad_request, "-o", str(tmp_path / "m.mp4"), env={"PATH": str(Path(ZEROMODE).parent)})
    assert run.returncode == 2 and not (tmp_path / "m.mp4").exists()
    assert run.stderr.startswith("error [unavailable_format]") and "apt-get install ffmpeg" in run.stderr
