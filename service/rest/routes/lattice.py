"""POST /v1/design/auxetic, POST /v1/design/allosteric and POST /v1/design/allosteric/network —
coupled-module designs, and allostery inside a given network."""

from __future__ import annotations

from fastapi import APIRouter

from zeromode.operations import endpoints
from zeromode.service.wire.schemas.allostery import (
    AllostericRequest,
    AllostericResponse,
    NetworkAllostericRequest,
    NetworkAllostericResponse,
)
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.lattice import AuxeticRequest, AuxeticResponse

router = APIRouter(prefix="/v1/design", tags=["design"])


@router.post("/auxetic", response_model=AuxeticResponse, responses=ERROR_RESPONSES)
def post_auxetic(request: AuxeticRequest) -> dict:
    """A lattice of coupled symmetric modules with one nontrivial zero mode of the requested
    (negative) Poisson ratio, its usable strain range and its expanded and contracted finite
    states inside it; optionally refined and certified in the same call (solver/pipeline.py)."""
    return endpoints.auxetic(request).body


@router.post("/allosteric", response_model=AllostericResponse, responses=ERROR_RESPONSES)
def post_allosteric(request: AllostericRequest) -> dict:
    """Source nodes driven by their motion move the distal target nodes exactly as prescribed.
    A design missing the accuracy floors is answered 422 `inaccurate_design`, its detail carrying
    the best figures found (`best`)."""
    return endpoints.allosteric(request).body


@router.post("/allosteric/network", response_model=NetworkAllostericResponse, responses=ERROR_RESPONSES)
def post_allosteric_network(request: NetworkAllostericRequest) -> dict:
    """The smallest change found that makes a given rigid network respond exactly: driving the
    source moves the target as prescribed (motions), or strains the target pair by η* times the
    source pair's strain. Bars the response strains are removed and nodes added on solution
    spaces; the report lists what changed."""
    return endpoints.network_allosteric(request).body
