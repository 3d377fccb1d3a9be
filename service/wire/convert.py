"""Conversions between request models and solver objects (no mathematics here)."""

from __future__ import annotations

from zeromode.service.wire.schemas.common import FrameModel
from zeromode.solver.frame import Frame


def frame_from_model(model: FrameModel) -> Frame:
    return Frame.build(model.positions, model.edges, model.specified, dim=model.dim)
