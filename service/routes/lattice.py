"""POST /v1/design/auxetic and POST /v1/design/allosteric — coupled-module designs."""

from __future__ import annotations

import time

from fastapi import APIRouter

from zeromode.service.responses import allosteric_body, auxetic_body
from zeromode.service.schemas.allostery import AllostericRequest, AllostericResponse
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.lattice import AuxeticRequest, AuxeticResponse
from zeromode.solver.allostery import design_allosteric
from zeromode.solver.errors import InvalidInput
from zeromode.solver.lattice import auxetic_chain_3d, auxetic_sheet

router = APIRouter(prefix="/v1/design", tags=["design"])


@router.post("/auxetic", response_model=AuxeticResponse, responses=ERROR_RESPONSES)
def post_auxetic(request: AuxeticRequest) -> dict:
    """A lattice of coupled symmetric modules with one nontrivial zero mode of the requested
    (negative) Poisson ratio, with its expanded and contracted finite states."""
    t0 = time.perf_counter()
    if request.dim == 2:
        if len(request.cells) != 2:
            raise InvalidInput("invalid_size", "a 2D sheet needs cells = [n_x, n_y].")
        cell = tuple(request.cell or (1.0, 1.0))
        if len(cell) != 2:
            raise InvalidInput("invalid_cell", "a 2D module has cell = [w, h].")
        lat = auxetic_sheet(*request.cells, poisson=request.poisson_ratio, cell=cell, strain=request.strain)
    else:
        if len(request.cells) != 1:
            raise InvalidInput("invalid_size", "a 3D chain needs cells = [n].")
        block = tuple(request.cell or (1.0, 1.0, 1.0))
        if len(block) != 3:
            raise InvalidInput("invalid_cell", "a 3D block has cell = [w, h, l].")
        lat = auxetic_chain_3d(
            request.cells[0], poisson=request.poisson_ratio, block=block, strain=request.strain, seed=request.seed
        )
    return auxetic_body(lat, {"total": 1e3 * (time.perf_counter() - t0)})


@router.post("/allosteric", response_model=AllostericResponse, responses=ERROR_RESPONSES)
def post_allosteric(request: AllostericRequest) -> dict:
    """Source nodes driven by their motion move the distal target nodes exactly as prescribed."""
    t0 = time.perf_counter()
    result = design_allosteric(
        request.source.positions,
        request.source.motion,
        request.target.positions,
        request.target.motion,
        dim=request.dim,
        seed=request.options.seed,
        relay_spacing=request.options.relay_spacing,
    )
    return allosteric_body(result, {"total": 1e3 * (time.perf_counter() - t0)})
