"""Named design requests: the paper's own cases, each a body for POST /v1/design.

Each entry is (description, request). Coordinates are those of the paper where it gives them
(Supplementary "Avoiding States of Self Stress in 3 Dimensions"); the other cases follow its
figures: outward motion u_S = x_S of nodes on a square (2D) or a cube (3D).
"""

from __future__ import annotations

import copy

from zeromode.solver.errors import InvalidInput

_SQUARE = [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]
_CUBE = [[float(i), float(j), float(k)] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]
_FIVE = [[2, 0, 1], [1, 0, 2], [3, 0, 3], [3.5, -1, 2.5], [3.5, 1, 2.5]]
_FIVE_U = [[-0.8, 0, 0.8], [0.8, 0, -0.8], [-0.8, 0, 0], [0, -0.8, 0], [0, 0.8, 0]]

EXAMPLES: dict[str, tuple[str, dict]] = {
    "outward_2d": (
        "Fig. 3b: four nodes on a square moving outward; 2 unspecified nodes, 8 bars.",
        {"dim": 2, "positions": _SQUARE, "motions": [_SQUARE], "options": {"seed": 0}},
    ),
    "outward_2d_four_nodes": (
        "Fig. 3c: the same target with 4 unspecified nodes, 12 bars.",
        {
            "dim": 2,
            "positions": _SQUARE,
            "motions": [_SQUARE],
            "options": {"seed": 0, "n_unspecified": 4},
        },
    ),
    "cube_outward_3d": (
        "Fig. 3d–e: eight cube corners moving outward; the solution space is a sphere.",
        {"dim": 3, "positions": _CUBE, "motions": [_CUBE], "options": {"seed": 0}},
    ),
    "five_node_3d": (
        (
            "Supplement, 'Avoiding States of Self Stress in 3 Dimensions': the full-set solution "
            "curve is planar, so joining every node on it to all five specified nodes would create "
            "a self-stress; the dependent bars are detected and left out; N_D = 7, no self-stress."
        ),
        {"dim": 3, "positions": _FIVE, "motions": [_FIVE_U], "options": {"seed": 0}},
    ),
}


def example_names() -> list[str]:
    return sorted(EXAMPLES)


def example_request(name: str) -> dict:
    """A deep copy of the named request body; raises InvalidInput for an unknown name."""
    if name not in EXAMPLES:
        raise InvalidInput("unknown_example", f"no example named {name!r}; try one of {example_names()}.")
    return copy.deepcopy(EXAMPLES[name][1])


def example_description(name: str) -> str:
    example_request(name)
    return EXAMPLES[name][0]
