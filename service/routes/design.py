"""POST /v1/solution-space and POST /v1/design — the analytic quadric construction."""

from __future__ import annotations

import time

import numpy as np
from fastapi import APIRouter

from zeromode.service.convert import json_safe
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.design import (
    DesignRequest,
    DesignResponse,
    SolutionSpaceRequest,
    SolutionSpaceResponse,
    TwoConfigurationRequest,
    TwoConfigurationResponse,
)
from zeromode.solver.certificates import SDP_MAX_DIM, certify
from zeromode.solver.design import design
from zeromode.solver.errors import InvalidInput
from zeromode.solver.refine import RefinementFailed, refine
from zeromode.solver.solution_space import solution_space
from zeromode.solver.two_configuration import design_two_configurations

router = APIRouter(prefix="/v1", tags=["design"])


@router.post("/solution-space", response_model=SolutionSpaceResponse, responses=ERROR_RESPONSES)
def post_solution_space(request: SolutionSpaceRequest) -> dict:
    """All (x_U, u_U) of one unspecified node joined to every specified node (Ã, W̃, Q)."""
    space = solution_space(request.positions, request.motions, dim=request.dim)
    x_u, u_u = space.sample(request.samples, np.random.default_rng(request.seed))
    residual = np.abs(space.residuals(x_u, u_u)).max(initial=0.0) if len(x_u) else 0.0
    return {
        "nullity": space.nullity,
        "dimension": space.dimension,
        "kind": space.kind,
        "basis": space.w_tilde.tolist(),
        "quadric": space.quadric.tolist(),
        "samples": [{"position": p.tolist(), "motion": m.tolist()} for p, m in zip(x_u, u_u)],
        "max_constraint_residual": float(residual),
    }


def design_response(result, t0: float) -> dict:
    """The contract's design body for a verified solver Design."""
    return {
        "frame": result.frame.to_dict(),
        "modes": result.modes.tolist(),
        "report": {
            "analysis": result.analysis.counts(),
            "target_zero_modes": result.target_zero_modes,
            "unspecified_nodes": result.unspecified_nodes,
            "bars": result.frame.n_edges,
            "anchor_sets": [list(a) for a in result.anchor_sets],
            "conditioning": result.conditioning,
            "mode_residual": result.mode_residual,
            "timings_ms": {"total": 1e3 * (time.perf_counter() - t0)},
        },
    }


@router.post("/design", response_model=DesignResponse, responses=ERROR_RESPONSES)
def post_design(request: DesignRequest) -> dict:
    """Inverse design by judicious constraint placement: the requested motions become the only
    non-rigid zero modes of the returned frame (verified before it is returned)."""
    t0 = time.perf_counter()
    opts = request.options
    result = design(
        request.positions,
        request.motions,
        dim=request.dim,
        seed=opts.seed,
        n_unspecified=opts.n_unspecified,
    )
    body = design_response(result, t0)
    if opts.refine is not None:
        if len(request.motions) != 1:
            raise InvalidInput("invalid_options", "options.refine follows one motion; request a single motion.")
        r = opts.refine
        try:
            refined = refine(
                result.frame,
                motion_s=np.asarray(request.motions[0]),
                amplitude=r.amplitude,
                K=r.K,
                tol=r.tol,
                max_time_s=r.max_time_s,
            )
        except RefinementFailed as exc:
            refined = exc.best
        body["report"]["refinement"] = json_safe(refined.to_dict())
    if opts.certify:
        # The optimal-stiffness SDP is sized by the motions to suppress, p = dN − d(d+1)/2 − M;
        # past its limit the certificate keeps the uniform margin only.
        frame = result.frame
        p = frame.dim * frame.n_nodes - result.target_zero_modes
        body["report"]["certificate"] = certify(
            frame, list(result.modes), stiffness=p <= SDP_MAX_DIM
        ).to_dict()
    body["report"]["timings_ms"]["total"] = 1e3 * (time.perf_counter() - t0)
    return body


@router.post("/design/two-configuration", response_model=TwoConfigurationResponse, responses=ERROR_RESPONSES)
def post_two_configuration(request: TwoConfigurationRequest) -> dict:
    """A frame whose specified nodes can sit at `initial` and at `final` with every bar keeping
    its length (the midpoint frame's designed flex, by the averaging principle); whether one
    continuous motion joins the two configurations is traced and reported."""
    t0 = time.perf_counter()
    result = design_two_configurations(request.initial, request.final, dim=request.dim, seed=request.options.seed)
    frame = result.frame
    return {
        "frame": frame.to_dict(),
        "final_positions": result.final_positions.tolist(),
        "report": {
            "analysis": result.analysis_initial.counts(),
            "unspecified_nodes": frame.n_nodes - len(frame.specified),
            "bars": frame.n_edges,
            "max_length_mismatch": result.max_length_mismatch,
            "epsilon": result.epsilon,
            "path": result.path_note,
            "timings_ms": {"total": 1e3 * (time.perf_counter() - t0)},
        },
    }
