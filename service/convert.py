"""Conversions between request models and solver objects (no mathematics here)."""

from __future__ import annotations

import math

from zeromode.service.schemas.common import FrameModel
from zeromode.solver.frame import Frame


def frame_from_model(model: FrameModel) -> Frame:
    return Frame.build(model.positions, model.edges, model.specified, dim=model.dim)


def json_safe(value):
    """Non-finite numbers (e.g. an IPOPT iterate that diverged) become null: JSON has no NaN."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list):
        return [json_safe(v) for v in value]
    return value
