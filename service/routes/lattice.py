"""POST /v1/design/auxetic, POST /v1/design/allosteric and POST /v1/design/allosteric/network —
coupled-module designs, and allostery inside a given network."""

from __future__ import annotations

import time

from fastapi import APIRouter, HTTPException

from zeromode.service.documents import allosteric, allosteric_tolerance, auxetic
from zeromode.service.responses import (
    allosteric_body,
    auxetic_body,
    inaccurate_design_body,
    json_safe,
    network_allosteric_body,
)
from zeromode.service.schemas.allostery import (
    AllostericRequest,
    AllostericResponse,
    NetworkAllostericRequest,
    NetworkAllostericResponse,
)
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.lattice import AuxeticRequest, AuxeticResponse
from zeromode.solver.applications.allostery import InaccurateDesign
from zeromode.solver.applications.finite_strain import FiniteStrainUnreachable
from zeromode.solver.applications.network_allostery import tune_network
from zeromode.solver.frame import Frame

router = APIRouter(prefix="/v1/design", tags=["design"])


@router.post("/auxetic", response_model=AuxeticResponse, responses=ERROR_RESPONSES)
def post_auxetic(request: AuxeticRequest) -> dict:
    """A lattice of coupled symmetric modules with one nontrivial zero mode of the requested
    (negative) Poisson ratio, its usable strain range and its expanded and contracted finite
    states inside it; optionally refined and certified in the same call (solver/pipeline.py)."""
    t0 = time.perf_counter()
    try:
        result = auxetic(request)
    except FiniteStrainUnreachable as exc:
        raise HTTPException(422, detail={"code": exc.code, "message": exc.message, "best": json_safe(exc.best)}) from exc
    return auxetic_body(result, {"total": 1e3 * (time.perf_counter() - t0)})


@router.post("/allosteric", response_model=AllostericResponse, responses=ERROR_RESPONSES)
def post_allosteric(request: AllostericRequest) -> dict:
    """Source nodes driven by their motion move the distal target nodes exactly as prescribed.
    A design missing the accuracy floors is answered 422 `inaccurate_design`, its detail carrying
    the best figures found (`best`)."""
    t0 = time.perf_counter()
    try:
        result = allosteric(request)
    except InaccurateDesign as exc:
        raise HTTPException(422, detail=inaccurate_design_body(exc)) from exc
    tolerance = allosteric_tolerance(request, result)
    return allosteric_body(result, {"total": 1e3 * (time.perf_counter() - t0)}, tolerance)


@router.post("/allosteric/network", response_model=NetworkAllostericResponse, responses=ERROR_RESPONSES)
def post_allosteric_network(request: NetworkAllostericRequest) -> dict:
    """The smallest change found that makes a given rigid network respond exactly: driving the
    source moves the target as prescribed (motions), or strains the target pair by η* times the
    source pair's strain. Bars the response strains are removed and nodes added on solution
    spaces; the report lists what changed."""
    f = request.frame
    frame = Frame.build(f.positions, f.edges, dim=f.dim)
    result = tune_network(
        frame,
        request.source,
        request.target,
        source_motion=request.source_motion,
        target_motion=request.target_motion,
        strain_ratio=request.strain_ratio,
        seed=request.options.seed,
    )
    return network_allosteric_body(result, frame.edges)
