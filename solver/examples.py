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


# Fig. 4 (two motions) and the supplement's partitioned construction ("Combining Networks
# Through Judicious Constraint Placement"); the paper gives no coordinates for these, so the
# targets are seeded random ones of the same shape that reproduce the paper's counts.
EXAMPLES.update(
    {
        "two_mode_2d": (
            (
                "Fig. 4a–c: three specified nodes, two motions; one unspecified node where the two "
                "position conics meet (exact resultant), N_D = 5."
            ),
            {
                "dim": 2,
                "positions": [[0.3, -0.5], [-0.9, -1.0], [0.6, 0.8]],
                "motions": [
                    [[0.2, 0.5], [0.1, 0.9], [0.6, -1.0]],
                    [[0.7, -0.9], [0.5, -0.6], [0.7, 0.1]],
                ],
                "options": {"seed": 0},
            },
        ),
        "two_mode_3d": (
            (
                "Fig. 4d–f: four specified nodes, two motions; four unspecified nodes on the curve "
                "where the two quadric surfaces meet, N_D = 8."
            ),
            {
                "dim": 3,
                "positions": [[0.7, 0.2, -0.4], [-0.9, 0.9, 0.2], [0.6, 0.8, 0.4], [-0.6, 1.0, -0.4]],
                "motions": [
                    [[0.3, 0.2, 0.2], [0.1, 1.0, 0.0], [0.5, 0.0, 1.0], [1.0, -0.2, -0.4]],
                    [[0.7, 0.6, 0.4], [-0.2, -0.2, -0.7], [0.3, -0.8, -0.5], [0.3, -1.0, 0.7]],
                ],
                "options": {"seed": 0},
            },
        ),
        "six_node_2d": (
            (
                "Supplement, partitioned construction in 2D: six specified nodes, no node can join "
                "them all; modules of four specified nodes couple them, N_D = 4."
            ),
            {
                "dim": 2,
                "positions": [[0.4, 0.5], [-1.4, -1.0], [0.2, 0.2], [0.1, -0.4], [-1.3, -0.4], [-0.4, -0.8]],
                "motions": [[[-0.9, 0.8], [0.1, -0.8], [-0.7, -0.1], [0.0, 0.6], [-0.9, -0.5], [0.7, 0.8]]],
                "options": {"seed": 0},
            },
        ),
        "six_node_3d": (
            (
                "Supplement, partitioned construction in 3D: six specified nodes on an octahedron "
                "whose full solution space has no real point; modules of five and four nodes, N_D = 7."
            ),
            {
                "dim": 3,
                "positions": [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]],
                "motions": [[[-1, 1, 0], [2, 2, -1], [0, -1, 1], [1, 2, 2], [2, 2, 2], [-2, -2, 0]]],
                "options": {"seed": 0},
            },
        ),
    }
)


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
