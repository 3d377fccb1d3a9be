"""The service's documents, recognised by their fields: what ``zeromode plot``, ``zeromode export``,
POST /v1/plot and POST /v1/export accept besides their own bodies.

A document is a request or response body of /v1/design, /v1/design/auxetic,
/v1/design/allosteric, /v1/design/multistable or /v1/design/sequential — a request is designed
first (``endpoints.respond``), so a request and its response give the same document — a /v1/map
request or response (MAP: the module beside its map), a /v1/refine response, a /v1/motion
response (which has no frame: the frame it moved comes with it), or any other body with a
``frame``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel, ValidationError, model_validator

from zeromode.service.wire.convert import feature_points, module_from_model
from zeromode.service.wire.schemas.allostery import AllostericRequest
from zeromode.service.wire.schemas.common import FrameModel, Points
from zeromode.service.wire.schemas.design import DesignRequest
from zeromode.service.wire.schemas.lattice import AuxeticRequest, LatticeState
from zeromode.service.wire.schemas.multistable import MinimumModel, MultistableRequest, SpringsModel
from zeromode.service.wire.schemas.sequential import (
    ChainBody,
    DesignedModule,
    MapBody,
    SequentialRequest,
)
from zeromode.solver.errors import InvalidInput
from zeromode.solver.pipeline import RefineStage, ToleranceStage

# What a document is, by its fields (``kind``).
DESIGN, AUXETIC, ALLOSTERIC, REFINEMENT, MOTION, FRAME, MULTISTABLE, SEQUENTIAL, MAP = (
    "design", "auxetic", "allosteric", "refinement", "motion", "frame", "multistable", "sequential", "map"
)
# The fields that make a body a /v1/map answer (its ``frame`` is optional: answers before it had none).
MAP_FIELDS = frozenset({"input_pair", "output_pair", "d_in", "d_out", "lower", "upper"})


# The fields of each response the plotting and export code read (pydantic ignores the rest).
class DesignDocument(BaseModel):
    frame: FrameModel
    modes: list[Points] = []


class AuxeticReportFields(BaseModel):
    boundary: dict[str, list[int]] | None = None


class AuxeticDocument(DesignDocument):
    poisson_ratio: float
    states: list[LatticeState]
    report: AuxeticReportFields = AuxeticReportFields()


class AllostericReportFields(BaseModel):
    source: list[int]
    target: list[int]
    relays: list[int] = []
    achieved_target_motion: Points = []


class AllostericDocument(DesignDocument):
    report: AllostericReportFields


class MultistableDocument(DesignDocument):
    """A /v1/design/multistable response: the rods (``frame``), every node in each conformation
    and the springs."""

    conformations: list[Points]
    springs: SpringsModel
    minima: list[MinimumModel] = []


class UniformStateFields(BaseModel):
    positions: Points


class SolitonFields(BaseModel):
    """A soliton's part of a /v1/design/sequential response (issue #41 item 2): one spring per
    copy on the chain's nodes, and the chain with every copy at each fixed point."""

    springs: SpringsModel
    unstable: UniformStateFields | None = None
    stable: UniformStateFields | None = None


class SequentialDocument(BaseModel):
    """A /v1/design/sequential response: the designed module, its chain (or None) and, for a
    soliton, the springs that make its uniform states minima."""

    module: DesignedModule
    chain: ChainBody | None = None
    soliton: SolitonFields | None = None
    deviation: float | None = None
    map_rtol: float | None = None


class MapDocument(MapBody):
    """A /v1/map response: the module's frame (None in answers that predate it) and its map,
    whose samples d_in, d_out and slope are one per sample (at least one)."""

    frame: FrameModel | None = None

    @model_validator(mode="after")
    def _samples(self) -> MapDocument:
        if not self.d_in or not len(self.d_in) == len(self.d_out) == len(self.slope):
            raise ValueError("d_in, d_out and slope must hold the same number (at least one) of samples")
        return self


class PathDocument(BaseModel):
    """A finite motion: a /v1/motion response, or the path of a /v1/refine response."""

    path: list[Points]
    parameter: list[float] | None = None
    reference_index: int | None = None


def kind(doc: dict) -> str:
    """The kind of a response document: AUXETIC (``states`` and ``poisson_ratio``), ALLOSTERIC
    (``report`` with ``source``, ``target``, ``relays``), MULTISTABLE (``frame``,
    ``conformations`` and ``springs``), DESIGN (any other ``report``), REFINEMENT (``path`` and
    ``epsilon_after``), MOTION (``path`` and ``parameter``, no ``frame``), SEQUENTIAL
    (``module`` and ``map``, no ``frame``), MAP (a /v1/map response: MAP_FIELDS), else FRAME."""
    report = doc.get("report") if isinstance(doc.get("report"), dict) else {}
    if MAP_FIELDS <= doc.keys():
        return MAP
    if "frame" not in doc and "path" in doc and "parameter" in doc:
        return MOTION
    if "frame" not in doc and "module" in doc and "map" in doc:
        return SEQUENTIAL
    if {"frame", "conformations", "springs"} <= doc.keys():
        return MULTISTABLE
    if "states" in doc and "poisson_ratio" in doc:
        return AUXETIC
    if {"source", "target", "relays"} <= report.keys():
        return ALLOSTERIC
    if "report" in doc:
        return DESIGN
    if "path" in doc and "epsilon_after" in doc:
        return REFINEMENT
    return FRAME


def is_map_request(doc) -> bool:
    """A /v1/map request: ``frame``, ``input_pair`` and ``output_pair`` without the map."""
    return isinstance(doc, dict) and {"frame", "input_pair", "output_pair"} <= doc.keys() and "d_in" not in doc


def framed(doc: dict) -> dict:
    """What a picture shows of a sequential design (others unchanged): a
    /v1/design/sequential response (SEQUENTIAL) as its chain's frame at the orbit from d0 when it
    was chained, else the designed module's."""
    if isinstance(doc, dict) and kind(doc) == SEQUENTIAL:
        sequential = validated(doc, SequentialDocument)
        return {"frame": (sequential.chain or sequential.module).frame.model_dump()}
    return doc


def design_arguments(r: DesignRequest) -> dict:
    """design_pipeline's arguments for a /v1/design request (its operation and the prechecks'
    check_design_request take them)."""
    o = r.options
    return {
        "positions": r.positions, "motions": r.motions, "dim": r.dim, "seed": o.seed,
        "n_unspecified": o.n_unspecified,
        "refine_stage": None if o.refine is None else RefineStage(**o.refine.model_dump()),
        "certify_stage": o.certify,
        "tolerance_stage": None if o.tolerance is None else ToleranceStage(**o.tolerance.model_dump()),
    }


def multistable_arguments(r: MultistableRequest) -> dict:
    """design_multistable's arguments for a /v1/design/multistable request."""
    o = r.options
    return {
        "conformations": r.conformations, "barrier": o.barrier, "max_stiffness": o.max_stiffness,
        "dim": r.dim, "seed": o.seed, "bifurcation": o.bifurcation,
    }


def sequential_arguments(r: SequentialRequest) -> dict:
    """design_sequential's arguments for a /v1/design/sequential request (its operation and the
    prechecks' check_sequential take them): the features' map points, the start module (None:
    the two-triangle module), reach and the chain's n_modules and d0 (None without a chain).
    InvalidInput ``invalid_soliton`` for a request with both a chain and a soliton."""
    chain = r.chain
    if chain is not None and r.soliton is not None:
        raise InvalidInput("invalid_soliton", "ask for either a chain or a soliton, not both.")
    return {
        "points": feature_points(r.features), "start": None if r.start is None else module_from_model(r.start),
        "reach": r.reach, "n_modules": None if chain is None else chain.n_modules,
        "d0": None if chain is None else chain.d0,
    }


def allosteric_arguments(r: AllostericRequest) -> dict:
    """design_allosteric's arguments for a /v1/design/allosteric request (allostery.allosteric_inputs
    takes the same)."""
    return {
        "source_positions": r.source.positions, "source_motion": r.source.motion,
        "target_positions": r.target.positions, "target_motion": r.target.motion,
        "dim": r.dim, "seed": r.options.seed, "relay_spacing": r.options.relay_spacing,
        "relay_growth": r.options.relay_growth, "robustness": r.options.robustness,
    }


def auxetic_arguments(r: AuxeticRequest) -> dict:
    """auxetic_pipeline's arguments for a /v1/design/auxetic request — a 2D sheet (cells
    [n_x, n_y], cell [w, h]) or a 3D chain (cells [n], block [w, h, l]) with the refine, certify
    and tolerance stages it asks for — once its counts of cells and half-sizes fit its dim
    (InvalidInput ``invalid_size`` / ``invalid_cell``); check_auxetic_request takes the same."""
    cells, sizes = (2, 2) if r.dim == 2 else (1, 3)
    if len(r.cells) != cells:
        raise InvalidInput("invalid_size", f"a {r.dim}D lattice needs {cells} cell count(s).")
    if r.cell is not None and len(r.cell) != sizes:
        raise InvalidInput("invalid_cell", f"a {r.dim}D module has {sizes} half-sizes.")
    return {
        "dim": r.dim, "cells": r.cells, "poisson": r.poisson_ratio, "cell": r.cell, "strain": r.strain,
        "seed": r.seed,
        "refine_stage": None if r.refine is None else RefineStage(**r.refine.model_dump()),
        "certify_stage": r.certify,
        "tolerance_stage": None if r.tolerance is None else ToleranceStage(**r.tolerance.model_dump()),
        "finite_strain": None
        if r.finite_strain is None
        else (*r.finite_strain.strain_range, r.finite_strain.tolerance),
    }


def plain(value: Any) -> Any:
    """``value`` with numpy arrays and scalars as Python lists and numbers (what a request holds)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Mapping):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def validated(body: dict, model: type[BaseModel]):
    """``body`` read as ``model``; InvalidInput ``invalid_request`` naming the first bad field."""
    try:
        return model.model_validate(body)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ())) or "document"
        raise InvalidInput("invalid_request", f"{where}: {first.get('msg', 'invalid value')}.") from exc
