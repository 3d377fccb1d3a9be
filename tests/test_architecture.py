"""The layers stay apart (docs/architecture.md), read from the source with ast.

The import graph of every zeromode module (solver/, viz/, export/, service/, zeromode/; imports
inside functions and under TYPE_CHECKING count) has no circle, and no module imports a layer
above its own (LAYERS). solver/ is mathematics only: it imports nothing of the service, of drawing, of the wire format
(JSON, pydantic) or of the web. Routes hold no numerical code: no numpy or scipy. The user's
pipeline is chained in one place: only solver/pipeline.py calls both refinement and certificates.
"""

import ast
import graphlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOLVER = sorted((ROOT / "solver").rglob("*.py"))
ROUTES = sorted((ROOT / "service" / "rest" / "routes").glob("*.py"))

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


# Where each source tree is installed (pyproject.toml's package-dir).
TREES = {"solver": "zeromode.solver", "viz": "zeromode.viz", "export": "zeromode.export",
         "service": "zeromode.service", "zeromode": "zeromode"}
# The layers, lowest first: a module may import its own layer and those of lower ranks. A
# module belongs to the layer whose longest prefix names it. Layers of one rank (the doors)
# import each other in neither direction.
# solver/ is mathematics (numpy in and out), one layer per stage of the paper in the order the
# stages build on each other (docs/architecture.md): its foundations (errors, budget, progress,
# tolerances; any new top-level module until it is placed), then the frame with analysis (the
# frame scales itself with analysis/normalisation, and analysis reads frames), motion,
# construction, applications, certificates, and the pipeline that chains them.
LAYERS: list[dict[str, tuple[str, ...]]] = [
    {"solver": ("zeromode.solver",)},
    {"analysis": ("zeromode.solver.frame", "zeromode.solver.analysis")},
    {"motion": ("zeromode.solver.motion",)},
    {"construction": ("zeromode.solver.construction",)},
    {"applications": ("zeromode.solver.applications", "zeromode.solver.multistable"),  # multistable: a linkage by construction, springs on its motion
     "sequential": ("zeromode.solver.sequential",)},  # modules as maps, chains (over motion)
    {"soliton": ("zeromode.solver.sequential.soliton",)},  # springs (multistable) on a chain (sequential)
    {"certificates": ("zeromode.solver.certificates",)},
    {"pipeline": ("zeromode.solver.pipeline",)},
    {"viz": ("zeromode.viz",)},                     # pictures of arrays
    {"export": ("zeromode.export",)},               # files of a Takeaway (animations via viz)
    {"wire": ("zeromode.service.wire",)},           # settings, schemas, error bodies, results → bodies
    {"library": ("zeromode.operations", "zeromode._library", "zeromode.examples")},
    {"jobs": ("zeromode.service.jobs",)},           # the job engine: records, Dask tasks, sweeps
    {"rest": ("zeromode.service.rest",),            # the doors: REST, and `import zeromode`
     "facade": ("zeromode.__init__",)},
    {"cli": ("zeromode.service.cli",)},             # the command line, over all of them
]
# Packages whose __init__ holds no code of a layer (a version string, a docstring; zeromode.solver's
# re-exports the frame and analysis for ``from zeromode.solver import Frame``).
NEUTRAL = {"zeromode.service", "zeromode.solver"}


def module_files() -> dict[str, Path]:
    """Every zeromode module and its file; a package as its name, except the facade
    ``zeromode/__init__.py`` (``zeromode.__init__``, a layer of its own)."""
    modules = {}
    for tree, package in TREES.items():
        for path in (ROOT / tree).rglob("*.py"):
            parts = path.relative_to(ROOT / tree).with_suffix("").parts
            if parts[-1] == "__init__" and not (tree == "zeromode" and len(parts) == 1):
                parts = parts[:-1]
            modules[".".join((package, *parts))] = path
    return modules


MODULES = module_files()


def _target(name: str) -> str | None:
    """The zeromode module an imported name lives in (a package's name for its __init__)."""
    while name and name not in MODULES:
        if name == "zeromode":
            return "zeromode.__init__"
        name = name.rpartition(".")[0]
    return name or None


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """module → the zeromode modules it imports, anywhere in its source (absolute and
    relative imports; ``from package import name`` resolved to a submodule where there is one)."""
    graph = {}
    for module, path in modules.items():
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parent = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                    base = f"{parent}.{base}" if base else parent
                found.update(f"{base}.{alias.name}" for alias in node.names)
        graph[module] = {t for name in found if name.startswith("zeromode")
                         and (t := _target(name)) is not None and t != module}
    return graph


def layer_of(module: str) -> tuple[int, str]:
    """(rank, layer) of a module: the longest LAYERS prefix naming it."""
    found = [(len(prefix), rank, layer) for rank, layers in enumerate(LAYERS) for layer, prefixes in layers.items()
             for prefix in prefixes if module == prefix or module.startswith(prefix + ".")]
    assert found, f"{module} is in no layer of tests/test_architecture.py's LAYERS"
    _, rank, layer = max(found)
    return rank, layer


def circle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle of ``graph``, or None."""
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError as exc:
        return exc.args[1]
    return None


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """Every import of a layer above the importer's own, or of another layer of its rank."""
    bad = []
    for module, targets in graph.items():
        if module in NEUTRAL:
            continue
        rank, layer = layer_of(module)
        for target in targets - NEUTRAL:
            other_rank, other = layer_of(target)
            if other_rank > rank or (other_rank == rank and other != layer):
                bad.append(f"{module} ({layer}) imports {target} ({other})")
    return sorted(bad)


GRAPH = import_graph(MODULES)


def test_the_graph_is_read(tmp_path):
    # Guards the two tests below against a graph that lost its modules or edges (a test that
    # could not fail): every tree is there, known edges are seen, relative imports resolved.
    assert {m.split(".")[1] for m in MODULES if m.count(".")} >= {"solver", "viz", "export", "service", "operations"}
    assert "zeromode.solver.frame" in GRAPH["zeromode.service.wire.convert"]
    # Every LAYERS prefix names modules that exist: a stale prefix (a module renamed or removed)
    # would leave its layer's place in the picture unchecked.
    prefixes = [p for layers in LAYERS for names in layers.values() for p in names]
    stale = [p for p in prefixes if not any(m == p or m.startswith(p + ".") for m in MODULES)]
    assert not stale, f"LAYERS names no module for {stale}"
    assert "zeromode.service.wire.settings" in GRAPH["zeromode.service.rest.app"]
    source = tmp_path / "engine.py"
    source.write_text("def f():\n    from .sweeps import run_sweep\n    from ..wire import settings\n")
    assert import_graph({"zeromode.service.jobs.engine": source})["zeromode.service.jobs.engine"] == {
        "zeromode.service.jobs.sweeps", "zeromode.service.wire.settings"}


def test_the_checks_catch_a_circle_and_an_upward_import():
    graph = {"zeromode.service.jobs.engine": {"zeromode.service.jobs.sweeps"},
             "zeromode.service.jobs.sweeps": {"zeromode.service.jobs.engine"},
             "zeromode.solver.frame": {"zeromode.viz.picture"}, "zeromode.viz.picture": set(),
             # the solver's stages: motion/target once read the boundary sets from applications/lattice
             "zeromode.solver.motion.target": {"zeromode.solver.applications.lattice", "zeromode.solver.analysis.rank"},
             "zeromode.solver.tolerances": {"zeromode.solver.frame"}}
    assert set(circle(graph)) == {"zeromode.service.jobs.engine", "zeromode.service.jobs.sweeps"}
    assert upward_imports(graph) == [
        "zeromode.solver.frame (analysis) imports zeromode.viz.picture (viz)",
        "zeromode.solver.motion.target (motion) imports zeromode.solver.applications.lattice (applications)",
        "zeromode.solver.tolerances (solver) imports zeromode.solver.frame (analysis)",
    ]


def test_no_import_circle():
    found = circle(GRAPH)
    assert found is None, "import circle: " + " → ".join(found)


def test_no_layer_imports_upward():
    assert upward_imports(GRAPH) == []


def test_each_operation_has_one_route_that_only_calls_it():
    # One pipeline, three doors: the route of every operation is parse → call → serialise, a
    # single `return endpoints.<operation>(request).body` (FastAPI parses, the response model
    # serialises); the job engine runs the same functions (tasks.RUNNABLE ⊂ OPERATIONS).
    import importlib
    import inspect
    import textwrap

    from fastapi.routing import APIRoute

    from zeromode.operations.endpoints import OPERATIONS
    from zeromode.service.jobs.tasks import RUNNABLE

    served = {}
    for path in ROUTES:
        if path.stem == "__init__":
            continue
        module = importlib.import_module(f"zeromode.service.rest.routes.{path.stem}")
        for route in module.router.routes:
            if isinstance(route, APIRoute) and route.path in OPERATIONS and "POST" in route.methods:
                served[route.path] = route.endpoint
    assert served.keys() == OPERATIONS.keys()
    for path, endpoint in served.items():
        (function,) = ast.parse(textwrap.dedent(inspect.getsource(endpoint))).body
        body = [s for s in function.body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))]
        expected = f"return endpoints.{OPERATIONS[path].run.__name__}({function.args.args[0].arg}).body"
        assert [ast.unparse(s) for s in body] == [expected], f"{path}: {endpoint.__name__} does more than call its operation"
    assert RUNNABLE and all(RUNNABLE[p] is OPERATIONS[p] for p in RUNNABLE)


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


def test_heavy_requests_run_the_operations_and_only_file_routes_are_called():
    # The offload (service/rest/offload.py) answers a heavy request to an operation's endpoint
    # by that operation on a worker (tasks.execute_request), as its route and a job do; it calls
    # a route only where there is no operation: the routes that answer a file.
    from fastapi.responses import Response

    from zeromode.operations.endpoints import OPERATIONS
    from zeromode.service.jobs.heavy import ALWAYS
    from zeromode.service.rest import offload

    assert offload.FILE_ROUTES.isdisjoint(OPERATIONS) and ALWAYS <= OPERATIONS.keys()
    for path in offload.FILE_ROUTES:
        assert offload._route(path).response_class is Response, path
