"""A laid-out picture: shapes in pixels (y down), the one vocabulary both writers speak.

layout.py produces a Scene; svg.py writes it as SVG text and raster.py draws it with matplotlib
(PNG, PDF). Shapes are painted in order. ``cls`` and ``data`` are for machines reading the SVG
(class names and data-* attributes); the raster writer ignores them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Line:
    """A segment ends (2, 2); round caps."""

    ends: np.ndarray
    stroke: str
    width: float
    cls: str | None = None
    data: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True, eq=False)
class Polyline:
    """An open path points (n, 2), unfilled; round joins and caps."""

    points: np.ndarray
    stroke: str
    width: float
    cls: str | None = None
    data: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True, eq=False)
class Polygon:
    """A closed outline points (n, 2): fill (None: unfilled) of opacity ``opacity``, and an
    outline (stroke None: none) with mitred corners."""

    points: np.ndarray
    fill: str | None
    stroke: str | None = None
    width: float = 0.0
    opacity: float = 1.0
    cls: str | None = None
    data: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True, eq=False)
class Circle:
    centre: np.ndarray
    radius: float
    fill: str
    stroke: str | None = None
    width: float = 0.0
    cls: str | None = None
    data: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True, eq=False)
class Text:
    """Text whose baseline starts (anchor "start") or is centred (anchor "middle") at ``at``."""

    at: np.ndarray
    text: str
    size: float
    fill: str
    anchor: str = "start"
    cls: str | None = None


@dataclass(frozen=True, eq=False)
class Group:
    """Shapes painted together: shifted by ``offset`` and clipped to ``clip`` (x, y, w, h) when set."""

    shapes: tuple
    cls: str | None = None
    id: str | None = None
    clip: tuple[float, float, float, float] | None = None
    offset: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True, eq=False)
class Scene:
    """A white page of width × height pixels and its shapes."""

    width: float
    height: float
    shapes: tuple
