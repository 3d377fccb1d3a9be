"""The layers stay apart (docs/architecture.md), read from the source with ast.

solver/ is mathematics only: it imports nothing of the service, of drawing, of the wire format
(JSON, pydantic) or of the web. Routes hold no numerical code: no numpy or scipy. The user's
pipeline is chained in one place: only solver/pipeline.py calls both refinement and certificates.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOLVER = sorted((ROOT / "solver").rglob("*.py"))
ROUTES = sorted((ROOT / "service" / "routes").glob("*.py"))

NOT_IN_SOLVER = (
    "zeromode.service",
    "zeromode.viz",
    "zeromode_client",
    "fastapi",
    "starlette",
    "pydantic",
    "httpx",
    "json",
    "matplotlib",
    "cairosvg",
    "zeromode.export",
    "meshio",
    "networkx",
    "ezdxf",
)
NOT_IN_ROUTES = ("numpy", "scipy")
# viz draws and export writes files: neither reaches up to the service; viz not even to export.
ABOVE = {"viz": ("zeromode.service", "zeromode.export", "zeromode_client"), "export": ("zeromode.service", "zeromode_client")}


def imported_modules(path: Path) -> set[str]:
    """Every dotted name ``path`` imports; ``from m import x`` gives m and m.x (x may be a module)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def called_names(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {
        node.func.id if isinstance(node.func, ast.Name) else node.func.attr
        for node in ast.walk(tree)
        if isinstance(node, ast.Call) and isinstance(node.func, (ast.Name, ast.Attribute))
    }


def test_the_trees_are_there():
    # Guards the parametrisations below against an empty glob (a test that could not fail).
    assert len(SOLVER) >= 15 and len(ROUTES) >= 5


@pytest.mark.parametrize("path", SOLVER, ids=lambda p: p.name)
def test_solver_imports_no_service_drawing_or_wire_format(path):
    bad = {
        name
        for name in imported_modules(path)
        if any(name == banned or name.startswith(banned + ".") for banned in NOT_IN_SOLVER)
    }
    assert not bad, f"{path.name} imports {sorted(bad)}"


@pytest.mark.parametrize("path", ROUTES, ids=lambda p: p.name)
def test_routes_hold_no_numerical_code(path):
    bad = {
        name
        for name in imported_modules(path)
        if any(name == banned or name.startswith(banned + ".") for banned in NOT_IN_ROUTES)
    }
    assert not bad, f"{path.name} imports {sorted(bad)}"


def test_only_the_pipeline_chains_refinement_and_certificates():
    chaining = [
        path.relative_to(ROOT).as_posix()
        for path in [*SOLVER, *ROOT.glob("service/**/*.py")]
        if {"refine", "certify"} <= called_names(path)
    ]
    assert chaining == ["solver/pipeline.py"]


@pytest.mark.parametrize(
    "path", [p for layer in ABOVE for p in sorted((ROOT / layer).glob("*.py"))], ids=lambda p: f"{p.parent.name}/{p.name}"
)
def test_viz_and_export_do_not_reach_up(path):
    banned = ABOVE[path.parent.name]
    bad = {name for name in imported_modules(path) if any(name == b or name.startswith(b + ".") for b in banned)}
    assert not bad, f"{path.parent.name}/{path.name} imports {sorted(bad)}"


# The solver's stages in the paper's order (docs/architecture.md): a module imports only from its
# own stage or from stages below it. The frame sits with analysis (it scales itself with
# analysis/normalisation, and analysis reads frames); errors, budget, progress and tolerances
# import no stage; the package's __init__ only re-exports.
STAGES = ("errors budget progress tolerances", "frame analysis", "motion", "construction", "applications", "certificates", "pipeline __init__")
STAGE_OF = {name: level for level, names in enumerate(STAGES) for name in names.split()}


def solver_stage(module: str) -> int:
    """The stage level of ``zeromode.solver.<part>...`` (its first part: a subpackage or a top module)."""
    return STAGE_OF[module.split(".")[2]]


def solver_imports(path: Path) -> set[str]:
    """The zeromode.solver modules (and names in them) ``path`` imports."""
    return {name for name in imported_modules(path) if name.startswith("zeromode.solver.")}


def stage_of(path: Path) -> str:
    """The stage name of a file under solver/: its subpackage, or its module name at the top."""
    return path.relative_to(ROOT / "solver").parts[0].removesuffix(".py")


def stage_violations(path: Path, stage: str) -> list[str]:
    """The zeromode.solver modules ``path`` imports from a later stage than ``stage``."""
    return sorted(name for name in solver_imports(path) if solver_stage(name) > STAGE_OF[stage])


def test_every_solver_module_has_a_stage():
    assert {stage_of(path) for path in SOLVER} == set(STAGE_OF)


@pytest.mark.parametrize("path", SOLVER, ids=lambda p: p.relative_to(ROOT / "solver").as_posix())
def test_solver_imports_run_down_the_stages(path):
    bad = stage_violations(path, stage_of(path))
    assert not bad, f"{path.relative_to(ROOT).as_posix()} ({stage_of(path)}) imports {bad} from a later stage"


def test_the_stage_check_sees_upward_imports(tmp_path):
    # Both import forms, upward from motion; the same lines are allowed from certificates.
    probe = tmp_path / "probe.py"
    probe.write_text(
        "import numpy\nfrom zeromode.solver import tolerances, pipeline\n"
        "def f():\n    from zeromode.solver.applications.lattice import boundary_sets\n",
        encoding="utf-8",
    )
    lattice = ["zeromode.solver.applications.lattice", "zeromode.solver.applications.lattice.boundary_sets"]
    assert stage_violations(probe, "motion") == [*lattice, "zeromode.solver.pipeline"]
    assert stage_violations(probe, "certificates") == ["zeromode.solver.pipeline"]
    assert stage_violations(probe, "pipeline") == []


# Thresholds are named once, with their reason, in solver/tolerances.py: a float literal in this
# range anywhere else in solver/ is a threshold (or a small step) without a name.
SMALL_FLOATS = (1e-16, 1e-4)


def small_float_literals(source: str) -> list[tuple[int, float]]:
    """(line, value) of every float constant with SMALL_FLOATS[0] ≤ |value| ≤ SMALL_FLOATS[1]."""
    return sorted(
        (node.lineno, node.value)
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.Constant)
        and isinstance(node.value, float)
        and SMALL_FLOATS[0] <= abs(node.value) <= SMALL_FLOATS[1]
    )


def test_the_literal_scan_sees_thresholds():
    source = "A = 1e-9\ndef f(x, tol=1e-6):\n    return x < -1e-12 * 2 or x > 1e-3 or x < 1e-300 or x == 0.0 or x < 1 / 3\n"
    assert small_float_literals(source) == [(1, 1e-9), (2, 1e-6), (3, 1e-12)]


@pytest.mark.parametrize("path", [p for p in SOLVER if p != ROOT / "solver" / "tolerances.py"], ids=lambda p: p.relative_to(ROOT / "solver").as_posix())
def test_no_threshold_outside_tolerances(path):
    found = small_float_literals(path.read_text(encoding="utf-8"))
    assert not found, f"{path.relative_to(ROOT).as_posix()}: float literals {found} belong in solver/tolerances.py, named with their reason"
