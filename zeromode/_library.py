"""The library's functions: each validates its arguments as the REST request of the same call
(zeromode.service.schemas: the same defaults, limits and 4xx-worthy refusals, raised here as
zeromode.solver.errors.InvalidInput), runs the one pipeline its route runs (solver/pipeline.py
and the solver functions of service/routes), and wraps the answer with its REST body
(zeromode.service.responses) in a result object (zeromode._results).

Domain failures are raised as the solver raises them (a DomainError with ``code``: the 422 of
the REST call; refinement, motion and allostery failures carry their best result).

Examples below use the paper's Fig. 3b: four specified nodes on a square moving outward,
u_S = x_S.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from zeromode._results import (
    AnalysisResult,
    CertificateResult,
    DesignResult,
    MapResult,
    MotionResult,
    RefineResult,
    Result,
    SequentialResult,
)

if TYPE_CHECKING:
    import pandas as pd

    from zeromode.solver.frame import Frame

__all__ = [
    "allosteric",
    "analyze",
    "auxetic",
    "certify",
    "design",
    "module_map",
    "motion",
    "refine",
    "sequential",
    "sweep",
    "two_configuration",
]

Points = Sequence[Sequence[float]]


def plain(value: Any) -> Any:
    """``value`` with numpy arrays and scalars as Python lists and numbers (what a request holds)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Mapping):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def _frame_body(frame: Frame | Result | Mapping) -> dict:
    """The contract's Frame of a Frame, a library result (its frame) or a Frame body."""
    if isinstance(frame, Result):
        return frame.frame_body()
    if isinstance(frame, Mapping):
        return plain(frame)
    from zeromode.service.responses import frame_body

    return frame_body(frame)


def _schema(model_name: str) -> Any:
    """The model ``module.Name`` of zeromode.service.schemas."""
    import importlib

    module, name = model_name.rsplit(".", 1)
    return getattr(importlib.import_module(f"zeromode.service.schemas.{module}"), name)


def _request(model_name: str, body: dict) -> Any:
    """``body`` validated as the REST request model ``model_name`` (InvalidInput naming the
    first bad field, as documents.validated refuses a document)."""
    from zeromode.service.documents import validated

    return validated(plain(body), _schema(model_name))


def _wire(model_name: str, body: dict) -> dict:
    """The body as the route's response model sends it (absent optional fields as null), as a
    job's answer is made (service.tasks.answer)."""
    return _schema(model_name).model_validate(body).model_dump(mode="json")


def _dim(points: Points, dim: int | None) -> int:
    return dim if dim is not None else len(points[0])


def _total_ms(t0: float) -> dict[str, float]:
    """The routes' ``timings_ms`` of a call that times one stage: its wall time in ms."""
    return {"total": 1e3 * (time.perf_counter() - t0)}


# ----------------------------------------------------------------------------- analysis


def analyze(frame: Frame | Result | Mapping, **options: Any) -> AnalysisResult:
    """Zero modes, rigid motions and self-stresses of a frame (POST /v1/analyze).

    The compatibility matrix C (paper, Eq. 3: row e = (i, j) holds (x_i − x_j)ᵀ at node i and
    (x_j − x_i)ᵀ at node j) is ranked; its null space holds the zero modes (C u = 0, Eq. 2), the
    null space of Cᵀ the self-stresses.

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame (a ``Frame``, a library result's frame, or {"dim", "positions", "edges"}).
    **options
        The request's ``options``: ``rtol``, ``method`` ("auto", "dense", "sparse"), ``bases``,
        ``gap_rtol``.

    Returns
    -------
    AnalysisResult
        Counts (``rank``, ``zero_modes``, ``nontrivial_zero_modes``, ``self_stresses``, …) read
        from the solver's Analysis; ``modes`` (M, N, d) orthonormal and ⟂ rigid motions.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = zm.Frame.build([[1, 1], [-1, 1], [-1, -1], [1, -1]], [[0, 1], [1, 2], [2, 3], [3, 0]])
    >>> a = zm.analyze(square); (a.rank, a.nontrivial_zero_modes, a.self_stresses)
    (4, 1, 0)
    """
    from zeromode.service.convert import frame_from_model
    from zeromode.service.responses import analyze_body
    from zeromode.service.settings import current_settings
    from zeromode.solver.analysis.rigidity import analyze as analyze_frame
    from zeromode.solver.progress import progress_stage

    request = _request("analyze.AnalyzeRequest", {"frame": _frame_body(frame), "options": options})
    t0 = time.perf_counter()
    o = request.options
    with progress_stage(0.0, 1.0, "analysis", detail=True):
        result = analyze_frame(
            frame_from_model(request.frame), rtol=o.rtol, method=o.method, bases=o.bases,
            basis_limit=current_settings().max_basis_numbers, gap_rtol=o.gap_rtol,
        )
    return AnalysisResult(request, result, _wire("analyze.AnalyzeResponse", analyze_body(result, _total_ms(t0))))


# ----------------------------------------------------------------------------- design


def design(positions: Points, motions: Points | Sequence[Points], *, dim: int | None = None,
           **options: Any) -> DesignResult:
    """A frame whose only non-rigid zero modes are the given motions (POST /v1/design).

    Judicious constraint placement: each unspecified node is placed on the solution space of
    the specified nodes' motions (paper, Eqs. 4–7: Ã (x_U, u_U) = 0 and its quadric), joined to
    them by bars that the motions keep at first order; the designed frame is verified by one
    rigidity analysis. solver.pipeline.design_pipeline, with the stages ``options`` ask for.

    Parameters
    ----------
    positions : (k, d) array_like
        x_S, the specified nodes.
    motions : (k, d) or (M, k, d) array_like
        One motion u_S or M motions, each a row per specified node.
    dim : {2, 3}, optional
        The dimension (by default the width of ``positions``).
    **options
        The request's ``options``: ``seed``, ``n_unspecified``, ``refine`` (a dict of refinement
        options), ``certify`` (bool), ``tolerance`` (a dict).

    Returns
    -------
    DesignResult
        ``frame`` (specified nodes first), ``modes`` (M, N, d): the designed motions extended to
        every node; ``solution`` is the solver's PipelineResult.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> d = zm.design(square, square); d.to_dict()["report"]["bars"], d.modes.shape
    (8, (1, 6, 2))
    """
    import numpy as np

    from zeromode.service.documents import design_arguments
    from zeromode.service.responses import design_body
    from zeromode.solver.pipeline import design_pipeline

    motions = plain(motions)
    if np.ndim(motions) == 2:  # one motion
        motions = [motions]
    request = _request("design.DesignRequest", {
        "dim": _dim(positions, dim), "positions": positions, "motions": motions, "options": options,
    })
    result = design_pipeline(**design_arguments(request))
    return DesignResult(request, result, _wire("design.DesignResponse", design_body(result, result.timings_ms)))


def auxetic(poisson_ratio: float, cells: Sequence[int] = (4, 4), **fields: Any) -> DesignResult:
    """A lattice of coupled symmetric modules with one nontrivial zero mode of Poisson ratio ν
    (POST /v1/design/auxetic; the paper's Fig. 5a).

    ν = −ε_y / ε_x of the lattice's mode, measured on its boundary; a 2D sheet of n_x × n_y
    modules (``cells`` of two) or a 3D chain of n blocks (``cells`` of one). Its usable strain
    range and expanded and contracted finite states come with it.

    Parameters
    ----------
    poisson_ratio : float
        ν of the mode.
    cells : sequence of int
        (n_x, n_y) modules of a sheet, or (n,) blocks of a chain.
    **fields
        The request's other fields: ``cell``, ``strain``, ``seed``, ``refine``, ``certify``,
        ``tolerance``, ``finite_strain``.

    Returns
    -------
    DesignResult
        ``solution`` is the solver's AuxeticResult (``solution.lattice``).

    Examples
    --------
    >>> import zeromode as zm
    >>> sheet = zm.auxetic(-0.5, (2, 2)); print(round(sheet.to_dict()["poisson_ratio"], 6))
    -0.5
    """
    from zeromode.service.documents import auxetic as auxetic_design
    from zeromode.service.responses import auxetic_body

    request = _request("lattice.AuxeticRequest", {
        "dim": 2 if len(cells) == 2 else 3, "cells": cells, "poisson_ratio": poisson_ratio, **fields,
    })
    t0 = time.perf_counter()
    result = auxetic_design(request)
    return DesignResult(request, result, _wire("lattice.AuxeticResponse", auxetic_body(result, _total_ms(t0))))


def allosteric(source: Any, target: Any, *, frame: Frame | Result | Mapping | None = None,
               dim: int | None = None, source_motion: Points | None = None,
               target_motion: Points | None = None, strain_ratio: float | None = None,
               **options: Any) -> DesignResult:
    """Allostery: driving the source moves the distal target exactly as prescribed
    (POST /v1/design/allosteric; with ``frame``, POST /v1/design/allosteric/network).

    From scratch, each site is specified nodes with a motion, and the network between them is
    designed as in ``design`` (paper, Fig. 5b: relays on the sites' solution spaces). In a given
    ``frame``, the smallest change found (bars removed, nodes added on solution spaces) makes
    the source's motion (or strain) move the target's (or strain it by ``strain_ratio``).

    Parameters
    ----------
    source, target : site or node indices
        From scratch: {"positions": (k, d), "motion": (k, d)} or a pair (positions, motion).
        In a frame: the node indices of each site.
    frame : Frame, result or Frame body, optional
        The given network.
    dim : {2, 3}, optional
        From scratch: the dimension (by default the sites' width).
    source_motion, target_motion, strain_ratio
        In a frame: the motions of the sites, or the target pair's strain over the source pair's.
    **options
        The request's ``options`` (seed; from scratch also relay_spacing, relay_growth, tolerance).

    Returns
    -------
    DesignResult
        ``solution``: the solver's AllostericDesign or NetworkAllostery.

    Examples
    --------
    >>> import zeromode as zm
    >>> site = lambda x0: {"positions": [[x0, 0], [x0 + 1, 0], [x0, 1]], "motion": [[1, 0], [0, 1], [1, 1]]}
    >>> a = zm.allosteric(site(0), site(6)); a.to_dict()["report"]["target_error"] < 1e-8
    True
    """
    from zeromode.service.responses import allosteric_body, network_allosteric_body

    if frame is not None:
        from zeromode.solver.applications.network_allostery import tune_network
        from zeromode.solver.frame import Frame as SolverFrame

        request = _request("allostery.NetworkAllostericRequest", {
            "frame": _frame_body(frame), "source": source, "target": target, "source_motion": source_motion,
            "target_motion": target_motion, "strain_ratio": strain_ratio, "options": options,
        })
        f = request.frame
        given = SolverFrame.build(f.positions, f.edges, dim=f.dim)
        result = tune_network(
            given, request.source, request.target, source_motion=request.source_motion,
            target_motion=request.target_motion, strain_ratio=request.strain_ratio, seed=request.options.seed,
        )
        return DesignResult(request, result, _wire(
            "allostery.NetworkAllostericResponse", network_allosteric_body(result, given.edges)
        ))
    from zeromode.service.documents import allosteric as allosteric_design
    from zeromode.service.documents import allosteric_tolerance

    sites = [s if isinstance(s, Mapping) else {"positions": s[0], "motion": s[1]} for s in (source, target)]
    request = _request("allostery.AllostericRequest", {
        "dim": _dim(sites[0]["positions"], dim), "source": sites[0], "target": sites[1], "options": options,
    })
    t0 = time.perf_counter()
    result = allosteric_design(request)
    tolerance = allosteric_tolerance(request, result)
    return DesignResult(request, result, _wire(
        "allostery.AllostericResponse", allosteric_body(result, _total_ms(t0), tolerance)
    ))


def two_configuration(initial: Points, final: Points, *, dim: int | None = None, seed: int = 0) -> DesignResult:
    """A frame whose specified nodes can sit at ``initial`` and at ``final`` with every bar
    keeping its length (POST /v1/design/two-configuration).

    The averaging principle: the midpoint frame (x_S + y_S)/2 designed with the flex
    (y_S − x_S)/2 keeps every bar length at both ends (|l(y) − l(x)| = 0 by Eq. 2 on the
    midpoint). Whether one continuous motion joins them is traced and reported.

    Parameters
    ----------
    initial, final : (k, d) array_like
        x_S and y_S.
    dim : {2, 3}, optional
        The dimension (by default the width of ``initial``).
    seed : int
        The design's seed.

    Returns
    -------
    DesignResult
        ``solution`` is the solver's TwoConfigurationDesign.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> t = zm.two_configuration(square, [[1.5 * x, 1.5 * y] for x, y in square])
    >>> t.to_dict()["report"]["max_length_mismatch"] < 1e-9
    True
    """
    from zeromode.service.responses import two_configuration_body
    from zeromode.solver.construction.two_configuration import design_two_configurations

    request = _request("design.TwoConfigurationRequest", {
        "dim": _dim(initial, dim), "initial": initial, "final": final, "options": {"seed": seed},
    })
    t0 = time.perf_counter()
    result = design_two_configurations(request.initial, request.final, dim=request.dim, seed=request.options.seed)
    return DesignResult(request, result, _wire(
        "design.TwoConfigurationResponse", two_configuration_body(result, _total_ms(t0))
    ))


# ----------------------------------------------------------------------------- beyond the linear design


def motion(frame: Frame | Result | Mapping, mode: int | Points | None = None, **fields: Any) -> MotionResult:
    """The finite motion of a frame along a zero mode (POST /v1/motion).

    Predictor–corrector continuation: every configuration keeps every bar length (Eq. 2 at
    finite amplitude, max_relative_bar_error ≤ 1e-9) and is aligned to the input frame.

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame to move.
    mode : int or (N, d) array_like, optional
        A mode, or the number of one of the result's ``modes``; by default the frame's one
        nontrivial zero mode.
    **fields
        The request's other fields: ``amplitude``, ``max_step``, ``max_steps``, ``direction``,
        ``on_singularity``, ``boundary``, ``target``.

    Returns
    -------
    MotionResult
        ``solution`` is the solver's MotionPath (``positions`` (P, N, d), ``parameter``).

    Raises
    ------
    SingularPath
        A singular point on the path with ``on_singularity="error"`` (the default), as the
        route's 422 ``singular_path``; ``exc.path`` is the path up to it.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> m = zm.design(square, square).motion(amplitude=0.2); m.to_dict()["max_relative_bar_error"] < 1e-9
    True
    """
    from zeromode.service.prechecks import motion_frame
    from zeromode.service.responses import motion_body
    from zeromode.solver.applications.lattice import path_strains
    from zeromode.solver.motion.finite_motion import SingularPath, trace_motion
    from zeromode.solver.motion.periodic import trace_motion_through_cell
    from zeromode.solver.motion.target import MotionTarget, aim_motion

    if isinstance(mode, int):  # the number of one of the result's modes, or of the frame's
        mode = (frame if isinstance(frame, Result) else analyze(frame)).modes[mode]
    request = _request("motion.MotionRequest", {"frame": _frame_body(frame), "mode": mode, **fields})
    t0 = time.perf_counter()
    moved = motion_frame(request)
    steps = request.model_dump(include={"mode", "max_step", "direction", "max_steps"})
    aimed = None
    if request.target is not None:
        target = MotionTarget(
            **request.target.model_dump(exclude={"nodes"}), nodes=tuple(request.target.nodes or ()),
            boundary=request.boundary,
        )
        aimed = aim_motion(moved, target, periodic=request.boundary is not None, **steps)
        path = aimed.path
    else:
        trace = trace_motion if request.boundary is None else trace_motion_through_cell
        path = trace(moved, amplitude=request.amplitude, **steps)
    strains = None if request.boundary is None else path_strains(moved.positions, path.positions, request.boundary)
    body = motion_body(path, _total_ms(t0), strains, aimed)
    if path.singularities and request.on_singularity == "error":
        raise SingularPath(path)
    return MotionResult(request, path, _wire("motion.MotionResponse", body))


def refine(frame: Frame | Result | Mapping, motion: Points | None = None, **fields: Any) -> RefineResult:
    """Move the unspecified nodes so that the finite motion carries the specified nodes to
    x_S + a Δ_S along a continuous path (POST /v1/refine).

    casadi + IPOPT with exact derivatives minimise the finite-motion infidelity ε(a) (the
    specified nodes' distance from x_S + a Δ_S along the traced path, over K configurations),
    reported before and after; the refined frame is re-verified (no new self-stress, one
    nontrivial zero mode at both ends).

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame, its ``specified`` nodes first.
    motion : (k, d) array_like, optional
        Δ_S; or give ``targets`` (k, d) instead.
    **fields
        The request's other fields: ``amplitude``, ``targets``, ``options`` (K, tol, max_iter,
        max_time_s, stay_on_solution_space).

    Returns
    -------
    RefineResult
        ``solution`` is the solver's Refinement (``epsilon_before``, ``epsilon_after``, …).

    Raises
    ------
    RefinementFailed
        IPOPT found no better frame (the route's 422); ``exc.best`` is the best one found.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> r = zm.design(square, square).refine().to_dict()
    >>> r["status"], r["epsilon_after"] <= r["epsilon_before"]
    ('ok', True)
    """
    from zeromode.service.convert import frame_from_model
    from zeromode.service.responses import refinement_body
    from zeromode.solver.motion.refine import refine as refine_frame

    request = _request("motion.RefineRequest", {"frame": _frame_body(frame), "motion": motion, **fields})
    result = refine_frame(
        frame_from_model(request.frame), motion_s=request.motion, amplitude=request.amplitude,
        targets=request.targets,
        **request.options.model_dump(include={"K", "tol", "max_iter", "max_time_s", "stay_on_solution_space"}),
    )
    return RefineResult(request, result, _wire("motion.RefineResponse", refinement_body(result)))


def certify(frame: Frame | Result | Mapping, modes: Sequence[Points] = (), **options: Any) -> CertificateResult:
    """Self-stress, prestress-stability and rigidity-margin certificates (POST /v1/certify).

    Self-stresses (Cᵀ s = 0) with their singular-value evidence; prestress stability decided by
    an SDP over the stresses, with its margin; the rigidity margin of the frame's motions beyond
    rigid motions and the designed ``modes``, for uniform and SDP-optimal bar stiffness.

    Parameters
    ----------
    frame : Frame, result or Frame body
        The frame.
    modes : sequence of (N, d) array_like
        The designed motions the margin leaves out.
    **options
        The request's ``options``: ``solver``, ``stiffness``, ``max_iters``.

    Returns
    -------
    CertificateResult
        ``solution`` is the solver's Certificate (``self_stress``, ``prestress``,
        ``rigidity_margin``).

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> c = zm.design(square, square).certify(); c.to_dict()["self_stress"]["count"]
    0
    """
    from zeromode.service.convert import frame_from_model
    from zeromode.service.responses import certificate_body
    from zeromode.solver.certificates.prestress import certify as certify_frame

    request = _request("certify.CertifyRequest", {"frame": _frame_body(frame), "modes": modes, "options": options})
    o = request.options
    result = certify_frame(
        frame_from_model(request.frame), request.modes, solver=o.solver, stiffness=o.stiffness, max_iters=o.max_iters
    )
    return CertificateResult(request, result, _wire("certify.CertifyResponse", certificate_body(result)))


def sweep(endpoint: str, template: Mapping | None = None, grid: Mapping[str, Sequence] | None = None,
          requests: Sequence[Mapping] | None = None, **options: Any) -> pd.DataFrame:
    """A sweep over one endpoint's requests, run on Dask without a server, as a DataFrame
    (zeromode.service.sweeps.sweep, which the REST sweeps and ``zeromode sweep`` run).

    Parameters
    ----------
    endpoint : str
        "/v1/design", "/v1/design/auxetic", … (or without "/v1/").
    template : dict, optional
        The request every point starts from.
    grid : dict of list, optional
        Dotted paths of the template and their values: every combination, the last fastest.
    requests : list of dict, optional
        Instead of a grid, one point per request merged over the template.
    **options
        ``scheduler`` (tcp://host:8786; by default a LocalCluster for this call), ``settings``,
        ``on_progress``.

    Returns
    -------
    pandas.DataFrame
        One row per point: ``param.<path>``, status, error code and the answer's scalar fields.

    Examples
    --------
    >>> import zeromode as zm
    >>> square = [[1, 1], [-1, 1], [-1, -1], [1, -1]]
    >>> zm.sweep("design", {"dim": 2, "positions": square, "motions": [square]},
    ...          {"options.n_unspecified": [2, 4]})["report.bars"].tolist()
    [8, 12]
    """
    from zeromode.service.sweeps import sweep as run

    path = endpoint if endpoint.startswith("/") else f"/v1/{endpoint}"
    return run(path, plain(template), plain(grid), plain(requests), **options)


# ----------------------------------------------------------------------------- sequential


def module_map(frame: Frame | Result | Mapping, input_pair: Sequence[int], output_pair: Sequence[int], *,
               at: Sequence[float] = ()) -> MapResult:
    """The map d_out = f(d_in) of a one-mode module between its input and output node pairs,
    from its exact finite motion (POST /v1/map; arXiv 1906.08400's modules as maps).

    Parameters
    ----------
    frame : Frame, result or Frame body
        A frame with exactly one nontrivial zero mode.
    input_pair, output_pair : (2,) node indices
        d_in = |x_a − x_b|, d_out = |x_c − x_e| (neither pair a bar).
    at : input distances
        Where f and f′ are evaluated exactly (inside the usable range).

    Returns
    -------
    MapResult
        ``solution`` is the solver's ModuleMap; ``to_dict()`` the samples, the usable range
        between folds, the fixed points and the values at ``at``; ``plot()`` the graph of f.

    Examples
    --------
    >>> import zeromode as zm
    >>> module = zm.Frame.build([[-1, 0], [1, 0], [-0.8, 1], [0.8, 1], [0.15, 0.45]],
    ...                         [[0, 2], [0, 4], [2, 4], [1, 3], [1, 4], [3, 4]])
    >>> m = zm.module_map(module, (0, 1), (2, 3), at=[1.0])
    >>> m.to_dict()["lower"]["kind"], round(m.to_dict()["evaluated"][0]["d_out"], 6)
    ('fold', 1.944466)
    """
    from zeromode.service.convert import module_from_model
    from zeromode.service.responses import module_map_body
    from zeromode.solver.sequential.module_map import module_map as map_of

    request = _request("sequential.MapRequest", {
        "frame": _frame_body(frame), "input_pair": input_pair, "output_pair": output_pair, "at": at,
    })
    t0 = time.perf_counter()
    solution = map_of(module_from_model(request))
    body = {**module_map_body(solution, request.at), "timings_ms": _total_ms(t0)}
    return MapResult(request, solution, _wire("sequential.MapResponse", body))


def sequential(features: Sequence[Mapping], *, n_modules: int | None = None, d0: float | None = None,
               start: Mapping | None = None, reach: float = 3.0) -> SequentialResult:
    """A module whose map has the requested features, and optionally a chain of ``n_modules``
    copies verified by continuation against the map's iterates (POST /v1/design/sequential).

    Parameters
    ----------
    features : list of dicts
        ``{"kind": "fixed_point", "d": d*, "slope": f′(d*)}``,
        ``{"kind": "period_two", "d1": …, "d2": …}`` or
        ``{"kind": "range", "source": [a, b], "target": [c, e]}``; met together, to map_rtol.
    n_modules : int, optional
        Chain this many copies (the output pair of one is the input pair of the next).
    d0 : float, optional
        The first copy's input distance (default: the first feature's first input).
    start : dict, optional
        ``{"frame": …, "input_pair": …, "output_pair": …}``, the module optimised (default: the
        two-triangle module).
    reach : float
        Nodes stay within this many RMS radii of the start's centre.

    Returns
    -------
    SequentialResult
        ``solution`` is the solver's SequentialDesign; a feature out of reach raises
        DomainError ``feature_out_of_reach`` with ``best``.

    Examples
    --------
    >>> import zeromode as zm
    >>> s = zm.sequential([{"kind": "fixed_point", "d": 1.5, "slope": -0.5}])
    >>> s.to_dict()["deviation"] <= s.to_dict()["map_rtol"]
    True
    """
    from zeromode.service.convert import feature_points, module_from_model
    from zeromode.service.responses import sequential_body
    from zeromode.solver.sequential.chain import design_sequential

    chain = None if n_modules is None else {"n_modules": n_modules, "d0": d0}
    request = _request("sequential.SequentialRequest", {
        "features": list(features), "start": start, "chain": chain, "reach": reach,
    })
    t0 = time.perf_counter()
    solution = design_sequential(
        feature_points(request.features),
        None if request.start is None else module_from_model(request.start),
        request.reach,
        None if request.chain is None else request.chain.n_modules,
        None if request.chain is None else request.chain.d0,
    )
    return SequentialResult(request, solution, _wire("sequential.SequentialResponse",
                                                     sequential_body(solution, _total_ms(t0))))
