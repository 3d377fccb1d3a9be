"""The paper's named cases (zeromode.service.wire.examples: GET /v1/examples, ``zeromode example``)
as /v1/design requests or as ready designs.

Examples
--------
>>> import zeromode as zm
>>> "outward_2d" in zm.examples.names()
True
>>> zm.examples.design("outward_2d").to_dict()["report"]["bars"]
8
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zeromode._library import DesignResult

__all__ = ["description", "design", "names", "request"]


def names() -> list[str]:
    """The examples' names, sorted (outward_2d: Fig. 3b; cube_outward_3d: Fig. 3d; two_mode_2d,
    two_mode_3d: Fig. 4; …)."""
    from zeromode.service.wire.examples import example_names

    return example_names()


def description(name: str) -> str:
    """One sentence naming the example's figure and counts."""
    from zeromode.service.wire.examples import example_description

    return example_description(name)


def request(name: str) -> dict:
    """A fresh copy of the example's /v1/design request body (InvalidInput ``unknown_example``
    for an unknown name)."""
    from zeromode.service.wire.examples import example_request

    return example_request(name)


def design(name: str) -> DesignResult:
    """The example designed by ``zeromode.design`` with its request's options.

    Examples
    --------
    >>> design("outward_2d_four_nodes").to_dict()["report"]["unspecified_nodes"]
    4
    """
    from zeromode._library import design as design_request

    body = request(name)
    return design_request(body["positions"], body["motions"], dim=body["dim"], **body.get("options", {}))
