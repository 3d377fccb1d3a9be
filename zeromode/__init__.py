"""zeromode — inverse design of bar-and-joint frames whose only non-rigid zero modes are the
motions you choose (Kim, Lu, Strogatz & Bassett, "Conformational control of mechanical
networks").

The library door: each function runs the one pipeline the REST service, its jobs and the CLI
run (zeromode.operations.endpoints) and returns a result that draws itself in Jupyter
(``_repr_svg_``), plots (``.plot()``), animates (``.animate()``), exports by suffix
(``.export(path)``), converts (``.to_networkx()``, ``.to_dict()`` — the REST body) and
continues the pipeline (``.refine()``, ``.certify()``, ``.motion()``). No server is needed.

Every name is loaded on first use (PEP 562), so ``import zeromode`` loads no numpy.

Examples
--------
>>> import zeromode as zm
>>> zm.analyze(zm.Frame.build([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1], [1, 2], [2, 3], [3, 0]])).nontrivial_zero_modes
1
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__all__ = [
    "Frame",
    "Result",
    "allosteric",
    "analyze",
    "auxetic",
    "certify",
    "design",
    "examples",
    "module_map",
    "motion",
    "multistable",
    "refine",
    "sequential",
    "solution_space",
    "sweep",
    "two_configuration",
]

# Where each public name lives: (module, attribute); None for a submodule.
_HOMES: dict[str, tuple[str, str | None]] = {
    "Frame": ("zeromode.solver.frame", "Frame"),
    "examples": ("zeromode.examples", None),
    # What every function returns (its subclasses name the function: DesignResult, …).
    "Result": ("zeromode._library", "Result"),
    # A sweep runs on the job engine's Dask cluster (the service's sweeps run the same code).
    "sweep": ("zeromode.service.jobs.sweeps", "sweep"),
    **{
        name: ("zeromode._library", name)
        for name in ("allosteric", "analyze", "auxetic", "certify", "design", "module_map", "motion", "multistable",
                     "refine", "sequential", "solution_space", "two_configuration")
    },
}

if TYPE_CHECKING:  # the names as a type checker sees them, without importing them at run time
    from zeromode import examples
    from zeromode._library import (
        Result,
        allosteric,
        analyze,
        auxetic,
        certify,
        design,
        module_map,
        motion,
        multistable,
        refine,
        sequential,
        solution_space,
        two_configuration,
    )
    from zeromode.service.jobs.sweeps import sweep
    from zeromode.solver.frame import Frame


def __getattr__(name: str) -> Any:
    """Load a public name on first use and keep it (PEP 562)."""
    if name not in _HOMES:
        raise AttributeError(f"module 'zeromode' has no attribute {name!r}")
    module, attribute = _HOMES[name]
    value = importlib.import_module(module)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
