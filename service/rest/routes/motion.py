"""POST /v1/motion — finite motion along a zero mode; POST /v1/refine — IPOPT refinement."""

from __future__ import annotations

from fastapi import APIRouter

from zeromode.operations import endpoints
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.motion import (
    MotionErrorResponse,
    MotionRequest,
    MotionResponse,
    RefineRequest,
    RefineResponse,
)

router = APIRouter(prefix="/v1", tags=["finite motion"])

RESPONSES = {
    **ERROR_RESPONSES,
    422: {
        "model": MotionErrorResponse,
        "description": (
            "Invalid request or domain failure; `singular_path` and `refinement_failed` carry the "
            "best result found in detail.best."
        ),
    },
}


@router.post("/motion", response_model=MotionResponse, responses=RESPONSES)
def post_motion(request: MotionRequest) -> dict:
    """Follow the finite motion of a frame along a zero mode by predictor–corrector continuation.

    Every configuration keeps every bar length (max_relative_bar_error ≤ 1e-9) and is aligned to
    the input frame (rigid motion removed). Singular points (extra zero modes: a branch point, or
    the frame locks) end the path in their direction and are reported; by default they answer
    422 `singular_path` with the path up to them. Sparse linear algebra above 400 degrees of
    freedom; frames beyond the continuation's limit (finite_motion.MAX_DOF) answer 422
    `too_expensive` before any work. With a lattice's `boundary`, every configuration's strain
    and secant Poisson ratio are reported, and a frame tiled by translations (recognised from its
    geometry) is followed through one cell and checked on the whole frame (method `periodic`: bar
    lengths at every configuration, the tiled tangent a zero mode, singular points of the frame
    located); where that check fails, the frame's own continuation answers. With a `target`
    (a distance, an angle, a lattice strain, a fraction of the usable range) the path ends
    exactly where it is reached (solver.motion.target), or 422 names why it cannot be.
    """
    return endpoints.motion(request).body


@router.post("/refine", response_model=RefineResponse, responses=RESPONSES)
def post_refine(request: RefineRequest) -> dict:
    """Move the unspecified nodes (casadi + IPOPT, exact derivatives) so that the finite motion
    carries the specified nodes to x_S + Δ_S along a continuous path.

    Reports ε before and after (finite-motion fidelity, measured by continuation), IPOPT's
    status, iterations and time. The refined frame is re-verified: no new self-stress and one
    nontrivial zero mode at both ends. Failure answers 422 `refinement_failed` with the best
    result in detail.best.
    """
    return endpoints.refine(request).body
