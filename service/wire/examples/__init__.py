"""The paper's named cases as ready request bodies (GET /v1/examples, ``zeromode example``), for
POST /v1/design unless a case names another endpoint.

Each case is one JSON file beside this module, ``<name>.json`` = {"description", "request"} and
optionally "endpoint" (the path the request is for; default /v1/design).
Coordinates are the paper's where it gives them (Supplementary "Avoiding States of Self Stress
in 3 Dimensions": five_node_3d); the Fig. 3 cases follow its figures: outward motion u_S = x_S
of nodes on a square (2D) or a cube (3D). For Fig. 4 (two motions) and the supplement's
partitioned construction ("Combining Networks Through Judicious Constraint Placement") the paper
gives no coordinates: their targets are seeded random ones of the same shape that reproduce the
paper's counts.
"""

from __future__ import annotations

import copy
import json
from functools import cache
from importlib.resources import files

from zeromode.solver.errors import InvalidInput

DEFAULT_ENDPOINT = "/v1/design"


@cache
def _examples() -> dict[str, dict]:
    return {
        path.name.removesuffix(".json"): json.loads(path.read_text(encoding="utf-8"))
        for path in files(__name__).iterdir()
        if path.name.endswith(".json")
    }


def example_names() -> list[str]:
    return sorted(_examples())


def _example(name: str) -> dict:
    if name not in _examples():
        raise InvalidInput("unknown_example", f"no example named {name!r}; try one of {example_names()}.")
    return _examples()[name]


def example_request(name: str) -> dict:
    """A fresh copy of the named request body; raises InvalidInput for an unknown name."""
    return copy.deepcopy(_example(name)["request"])


def example_description(name: str) -> str:
    return _example(name)["description"]


def example_endpoint(name: str) -> str:
    """The path the named request is for: /v1/design unless the case names another."""
    return _example(name).get("endpoint", DEFAULT_ENDPOINT)
