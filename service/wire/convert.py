"""Conversions between request models and solver objects (no mathematics here)."""

from __future__ import annotations

from zeromode.service.wire.schemas.common import FrameModel
from zeromode.solver.frame import Frame
from zeromode.solver.sequential.design import MapPoint, fixed_point, period_two, range_onto
from zeromode.solver.sequential.module_map import Module


def frame_from_model(model: FrameModel) -> Frame:
    return Frame.build(model.positions, model.edges, model.specified, dim=model.dim)


def module_from_model(model) -> Module:
    """A solver Module of a schemas.sequential.ModuleModel (pairs validated by Module.build)."""
    return Module.build(frame_from_model(model.frame), model.input_pair, model.output_pair)


def feature_points(features) -> tuple[MapPoint, ...]:
    """The map points (solver.sequential.design) of the request's features, in order."""
    points: list[MapPoint] = []
    for f in features:
        if f.kind == "fixed_point":
            points += fixed_point(f.d, f.slope)
        elif f.kind == "period_two":
            points += period_two(f.d1, f.d2)
        else:
            points += range_onto(f.source, f.target)
    return tuple(points)
