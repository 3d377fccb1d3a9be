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
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
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
