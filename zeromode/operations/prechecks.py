"""What each job endpoint refuses up front, without computing its answer: POST /v1/jobs and
every point of POST /v1/sweeps run ``precheck`` at submit, so a request its endpoint would
refuse at once is a 422 there, with the endpoint's own code.

Each check is the solver function the endpoint itself runs first (the pipelines call their
``check_*_request``, refine its ``refinement_target``, certify its ``check_certify_request``),
given the same arguments (zeromode/operations/documents.py builds them for both), so the rules exist once.
What is decided here, and what only the run can decide:

  /v1/analyze            the frame (Frame.build: shapes, finite numbers, edges, specified),
                         the dense route's size (too_expensive).  Run time: the sparse route's
                         null-space size (too_expensive).
  /v1/design             shapes, distinct specified nodes, non-rigid independent motions, the
                         motion count, n_unspecified, refinement of one motion.  Run time: the
                         stages' sizes (refine's unknowns, certificates, tolerances: the designed
                         frame's), no_solution of the placement.
  /v1/design/auxetic     cell and half-size counts, sizes, the cell's extent (out_of_range),
                         the module's conic (no_solution), a sheet colliding at rest
                         (no_solution, e.g. ν = 0), a sheet's strain (strain_out_of_range, from
                         one module's scan of its range, kept), a chain's couplings
                         (coupling_failed, e.g. ν = 0), the refine / certify / tolerance sizes on
                         the lattice's frame at rest (too_few_unknowns, too_expensive; a chain's
                         needs one block designed, kept), finite_strain's options.  Run time: a
                         chain's strain (its range is a continuation of the whole chain), a
                         finite-strain sheet's stages, finite_strain_unreachable, the lattice's
                         single mode.
  /v1/design/allosteric  shapes, options, the sites (overlap, rigid or zero motions, a source
                         that does not pin the rigid motions), the relays' module count
                         (too_expensive).  Run time: inaccurate_design, the tolerance stage.
  /v1/design/multistable the conformations (2 or 3, equal shapes, k ≥ d + 1 distinct nodes,
                         at most MAX_SPECIFIED: too_expensive; none a rigid motion of another:
                         rigid_target), a bifurcation's (three 2D conformations:
                         invalid_bifurcation).  Run time: no_linkage, no_path, no_bifurcation,
                         no_springs, not_verified.
  /v1/map                the frame, the pairs (two distinct nodes each, not a bar, the pairs
                         different: Module.build), the size (d·N ≤ MAP_MAX_DOF: too_expensive).
                         Run time: the module's modes (no_motion, ambiguous_mode),
                         input_fixed, reference_at_fold, out_of_range of `at`.
  /v1/design/sequential  the features (invalid_feature), the start module as /v1/map's and at
                         most DESIGN_MAX_NODES nodes, reach, a distance beyond the start's
                         reach (feature_out_of_reach), the NLP's ladder (MAX_LADDER:
                         too_expensive); with a chain, the module chainable (planar, no
                         self-stress, disjoint pairs).  Run time: feature_out_of_reach of the
                         design, chain_leaves_range, chain_mismatch.
  /v1/motion             the frame, its extent, direction / amplitude / max_step, the size
                         (too_expensive), the given mode's shape, the boundary sets.  Run time:
                         everything about the frame's modes (no_motion, ambiguous_mode,
                         not_a_zero_mode, a zero mode given), singular_path.
  /v1/refine             the frame, the target (motion and amplitude, or targets), no
                         unspecified node, K, the NLP's size (too_expensive, too_few_unknowns).
                         Run time: not_single_mode (an analysis), refinement_failed.
  /v1/certify            the frame, the solver, the sizes (too_expensive), the given modes
                         (invalid_modes: shape, zero mode, independence).  Run time:
                         certificate_failed, the prestress SDP's size (the frame's flexes).
"""

from __future__ import annotations

from collections.abc import Callable

from pydantic import BaseModel

from zeromode.operations.documents import (
    allosteric_arguments,
    auxetic_arguments,
    design_arguments,
    multistable_arguments,
    sequential_arguments,
)
from zeromode.service.wire.convert import frame_from_model, module_from_model
from zeromode.service.wire.schemas.allostery import AllostericRequest
from zeromode.service.wire.schemas.analyze import AnalyzeRequest
from zeromode.service.wire.schemas.certify import CertifyRequest
from zeromode.service.wire.schemas.design import DesignRequest
from zeromode.service.wire.schemas.lattice import AuxeticRequest
from zeromode.service.wire.schemas.motion import MotionRequest, RefineRequest
from zeromode.service.wire.schemas.multistable import MultistableRequest
from zeromode.service.wire.schemas.sequential import MapRequest, SequentialRequest
from zeromode.solver.analysis.rigidity import check_dense_size
from zeromode.solver.applications.allostery import allosteric_inputs
from zeromode.solver.certificates.prestress import check_certify_request
from zeromode.solver.frame import Frame, check_extent
from zeromode.solver.motion.boundary_strain import boundary_sets
from zeromode.solver.motion.finite_motion import check_trace_arguments, given_mode
from zeromode.solver.motion.refine import refinement_target
from zeromode.solver.multistable.bifurcation import check_bifurcation
from zeromode.solver.multistable.linkage import check_conformations
from zeromode.solver.pipeline import check_auxetic_request, check_design_request
from zeromode.solver.sequential.chain import check_sequential
from zeromode.solver.sequential.module_map import check_map_size
from zeromode.solver.sequential.soliton import check_soliton


def motion_frame(request: MotionRequest) -> Frame:
    """The frame of a /v1/motion request once everything refused before tracing has passed:
    the frame, its extent, the continuation's arguments and size, the given mode's shape, the
    boundary sets (its route calls this first)."""
    frame = frame_from_model(request.frame)
    check_extent(frame.positions)
    check_trace_arguments(frame, request.amplitude, request.max_step, request.direction)
    if request.mode is not None:
        given_mode(request.mode, frame.n_nodes, frame.dim)
    if request.boundary is not None:
        boundary_sets(request.boundary, frame.n_nodes)
    return frame


def _analyze(r: AnalyzeRequest) -> None:
    check_dense_size(frame_from_model(r.frame), r.options.method)


def _design(r: DesignRequest) -> None:
    check_design_request(**design_arguments(r))


def _auxetic(r: AuxeticRequest) -> None:
    check_auxetic_request(**auxetic_arguments(r))


def _allosteric(r: AllostericRequest) -> None:
    allosteric_inputs(**allosteric_arguments(r))


def _multistable(r: MultistableRequest) -> None:
    a = multistable_arguments(r)
    x = check_conformations(a["conformations"], a["dim"])
    if a["bifurcation"] is not None:
        check_bifurcation(a["bifurcation"], x)


def _map(r: MapRequest) -> None:
    check_map_size(module_from_model(r))


def _sequential(r: SequentialRequest) -> None:
    a = sequential_arguments(r)
    check_sequential(a["points"], a["start"], a["reach"], a["n_modules"])
    if r.soliton is not None:
        check_soliton(a["points"], r.soliton.n_modules, r.soliton.stiffness)


def _motion(r: MotionRequest) -> None:
    motion_frame(r)


def _refine(r: RefineRequest) -> None:
    o = r.options
    refinement_target(frame_from_model(r.frame), r.motion, r.amplitude, r.targets, o.K, o.stay_on_solution_space)


def _certify(r: CertifyRequest) -> None:
    o = r.options
    check_certify_request(frame_from_model(r.frame), r.modes or (), o.solver, o.stiffness)


PRECHECKS: dict[str, Callable] = {
    "/v1/analyze": _analyze,
    "/v1/design": _design,
    "/v1/design/auxetic": _auxetic,
    "/v1/design/allosteric": _allosteric,
    "/v1/design/multistable": _multistable,
    "/v1/map": _map,
    "/v1/design/sequential": _sequential,
    "/v1/motion": _motion,
    "/v1/refine": _refine,
    "/v1/certify": _certify,
}


def precheck(endpoint: str, body: BaseModel) -> None:
    """Raise what ``endpoint`` would answer up front for ``body`` (its request model, validated):
    the DomainError (InvalidInput included) its first checks raise; return when they pass.
    Typically under a few milliseconds; an auxetic sheet's ``strain`` costs one scan of a
    module's motion (50–400 ms) and a chain with stages one block's design (≈ 20 ms) per
    lattice, both kept for the run and the sweep's other points (lattice.py caches)."""
    PRECHECKS[endpoint](body)
