"""The one place that turns solver results into response bodies (the wire format).

Each function takes solver dataclasses (numpy inside) and returns the JSON-ready dict of one
response schema in service/schemas; routes, jobs and the CLI call these and nothing else
defines a body. Non-finite floats become null (JSON has no NaN) where a solver may produce
them: an IPOPT iterate that diverged.
"""

from __future__ import annotations

import json
import math
from dataclasses import fields
from datetime import UTC, datetime

import numpy as np

from zeromode.solver.analysis.rank import RankGap
from zeromode.solver.analysis.rigidity import Analysis
from zeromode.solver.certificates.fabrication import ToleranceEstimate, ToleranceReport
from zeromode.solver.certificates.prestress import (
    Certificate,
    LmiSolution,
    SelfStressCertificate,
)
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import FidelityCurve, MotionPath
from zeromode.solver.motion.target import AimedMotion

# The integer fields of /v1/analyze, in the contract's order (docs/API.md).
COUNT_FIELDS = (
    "nodes",
    "edges",
    "dim",
    "maxwell_count",
    "rank",
    "zero_modes",
    "rigid_body_modes",
    "nontrivial_zero_modes",
    "self_stresses",
)


def json_safe(value):
    """Non-finite numbers (e.g. an IPOPT iterate that diverged) become null: JSON has no NaN."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list):
        return [json_safe(v) for v in value]
    return value


# ----------------------------------------------------------------------------- frames, analysis


def frame_body(frame: Frame, specified=None) -> dict:
    """The contract's Frame; ``specified`` overrides the frame's own (allostery marks both sites)."""
    return {
        "dim": frame.dim,
        "positions": frame.positions.tolist(),
        "edges": frame.edges.tolist(),
        "specified": list(frame.specified if specified is None else specified),
    }


def rank_gap_body(gap: RankGap) -> dict:
    return {
        "last_nonzero": gap.last_nonzero,
        "first_zero": gap.first_zero,
        "last_nonzero_error": gap.last_nonzero_error,
    }


def counts_body(analysis: Analysis) -> dict:
    """The integer fields and the rank gap of /v1/analyze (also embedded as report.analysis)."""
    return {
        **{name: getattr(analysis, name) for name in COUNT_FIELDS},
        "rank_gap": rank_gap_body(analysis.rank_gap),
    }


def analyze_body(analysis: Analysis, timings_ms: dict) -> dict:
    return {
        **counts_body(analysis),
        "modes": analysis.modes.tolist(),
        "stresses": analysis.stresses.tolist(),
        "method": analysis.method,
        "bases_included": analysis.bases_included,
        "timings_ms": timings_ms,
    }


# ----------------------------------------------------------------------------- design


def solution_space_body(space, samples) -> dict:
    return {
        "nullity": space.nullity,
        "dimension": space.dimension,
        "kind": space.kind,
        "basis": space.w_tilde.tolist(),
        "quadric": space.quadric.tolist(),
        "samples": [
            {"position": p.tolist(), "motion": m.tolist()}
            for p, m in zip(samples.positions, samples.motions)
        ],
        "max_constraint_residual": samples.max_residual,
    }


def design_body(result, timings_ms: dict) -> dict:
    """/v1/design for a PipelineResult: the linear design, with its refinement and certificate."""
    d = result.design
    report = {
        "analysis": counts_body(d.analysis),
        "target_zero_modes": d.target_zero_modes,
        "unspecified_nodes": d.unspecified_nodes,
        "bars": d.frame.n_edges,
        "anchor_sets": [list(a) for a in d.anchor_sets],
        "conditioning": d.conditioning,
        "mode_residual": d.mode_residual,
        "timings_ms": timings_ms,
    }
    if result.refinement is not None:
        report["refinement"] = refinement_body(result.refinement)
    if result.certificate is not None:
        report["certificate"] = certificate_body(result.certificate)
    if result.tolerance is not None:
        report["tolerance"] = tolerance_body(result.tolerance)
    return {"frame": frame_body(d.frame), "modes": d.modes.tolist(), "report": report}


def two_configuration_body(result, timings_ms: dict) -> dict:
    frame = result.frame
    return {
        "frame": frame_body(frame),
        "final_positions": result.final_positions.tolist(),
        "report": {
            "analysis": counts_body(result.analysis_initial),
            "unspecified_nodes": frame.n_nodes - len(frame.specified),
            "bars": frame.n_edges,
            "max_length_mismatch": result.max_length_mismatch,
            "epsilon": result.epsilon,
            "path": result.path_note,
            "timings_ms": timings_ms,
        },
    }


def strain_range_body(usable) -> dict:
    end = lambda e: {"strain": e.strain, "reason": e.reason, "detail": e.detail}
    return {
        "lower": end(usable.lower),
        "upper": end(usable.upper),
        "proximity_fraction": usable.proximity_fraction,
        "shortest_bar": usable.shortest_bar,
    }


def auxetic_body(result, timings_ms: dict) -> dict:
    """/v1/design/auxetic for an AuxeticResult: the linear lattice, its states and usable range,
    with its refinement, certificate and tolerances when asked."""
    lattice = result.lattice
    body = {
        "frame": frame_body(lattice.frame),
        "modes": [lattice.mode.tolist()],
        "poisson_ratio": lattice.poisson_ratio,
        "states": [
            {"name": name, "positions": x.tolist(), "poisson_ratio": nu, "strain": eps}
            for name, (x, nu, eps) in sorted(lattice.states.items())
        ],
        "report": {
            "analysis": counts_body(lattice.analysis),
            "boundary": lattice.boundary,
            "mode_residual": lattice.mode_residual,
            "max_relative_bar_error": lattice.max_relative_bar_error,
            "strain_range": strain_range_body(lattice.strain_range),
            "min_node_distance": lattice.min_node_distance,
            "timings_ms": {**result.timings_ms, **timings_ms},
        },
    }
    if result.tolerance is not None:
        body["report"]["tolerance"] = tolerance_body(result.tolerance)
    if result.refinement is not None:
        body["report"]["refinement"] = refinement_body(result.refinement)
        body["report"]["refined_poisson_ratio"] = result.refined_poisson_ratio
    if result.certificate is not None:
        body["report"]["certificate"] = certificate_body(result.certificate)
    held = result.finite_strain
    if held is not None:
        body["report"]["finite_strain"] = {
            "strain_range": list(held.requested),
            "tolerance": held.tolerance,
            "strains": held.strains.tolist(),
            "secant_poisson_ratios": held.secant_ratios.tolist(),
            "max_deviation": held.max_deviation,
            "max_relative_bar_error": held.max_relative_bar_error,
            "module": {"family": held.family, "parameter": held.parameter, "coordinates": list(held.coordinates)},
        }
    return body


def allosteric_body(result, timings_ms: dict, tolerance: ToleranceReport | None = None) -> dict:
    d = result.design
    f = result.figures
    body = {
        "frame": frame_body(d.frame, specified=list(result.source) + list(result.target)),
        "modes": d.modes.tolist(),
        "report": {
            "analysis": counts_body(d.analysis),
            "source": list(result.source),
            "target": list(result.target),
            "relays": list(result.relays),
            "achieved_target_motion": f.achieved_target_motion.tolist(),
            **figures_body(f),
            "modules": result.modules,
            "chain": chain_body(result.options, result.site_size),
            "distance": result.distance,
            "unspecified_nodes": d.frame.n_nodes - len(result.source) - len(result.target),
            "bars": d.frame.n_edges,
            "mode_residual": d.mode_residual,
            "timings_ms": timings_ms,
        },
    }
    if tolerance is not None:
        body["report"]["tolerance"] = tolerance_body(tolerance)
    return body


def figures_body(f) -> dict:
    """The accuracy and robustness figures of an allosteric answer (allostery.ResponseFigures)."""
    return {
        "target_error": f.target_error,
        "gap": f.gap,
        "sensitivity": f.sensitivity,
        "motion_sensitivity": f.motion_sensitivity,
        "amplification": f.amplification,
        "amplification_worst": f.amplification_worst,
        "perturbation": f.perturbation,
    }


def chain_body(options, site_size: float) -> dict:
    """The chain parameters of an allosteric design (allostery.ChainOptions), relay_spacing in
    the request's units."""
    return {
        "relay_spacing": options.port * site_size,
        "relay_growth": options.growth,
        "module_aspect": options.aspect,
        "seed": options.seed,
        "gain_one": options.amplitude is not None,
    }


def inaccurate_design_best(exc) -> dict | None:
    """detail.best of allostery.InaccurateDesign's 422: the best figures found with the chain
    that gave them (None when no attempt could be built)."""
    if exc.best is None:
        return None
    return {**json_safe(figures_body(exc.best)), "chain": chain_body(exc.options, exc.site_size)}


def network_allosteric_body(result, given_edges) -> dict:
    """POST /v1/design/allosteric/network for a network_allostery.NetworkAllostery; given_edges:
    the given frame's edges (the removed bars are reported as their pairs too)."""
    frame = result.frame
    return {
        "frame": frame_body(frame),
        "modes": [result.mode.tolist()],
        "report": {
            "analysis": counts_body(result.analysis),
            "source": list(result.source),
            "target": list(result.target),
            "source_motion": result.source_motion.tolist(),
            "achieved_target_motion": result.achieved_target_motion.tolist(),
            "target_error": result.target_error,
            "strain_ratio": result.strain_ratio,
            "removed_edges": list(result.removed_edges),
            "removed_bars": np.asarray(given_edges)[list(result.removed_edges)].reshape(-1, 2).tolist(),
            "added_nodes": list(result.added_nodes),
            "added_edges": result.added_edges.tolist(),
            "moving": list(result.moving),
            "bonds_changed": result.bonds_changed,
            "mode_residual": result.mode_residual,
            "timings_ms": dict(result.timings_ms),
        },
    }


def elastic_allosteric_body(result, given_edges) -> dict:
    """POST /v1/design/allosteric/network with options.response "elastic", for an
    elastic_allostery.ElasticAllostery; given_edges: the given frame's edges."""
    given_edges = np.asarray(given_edges)
    tuned = None
    if result.tuned_edge is not None:
        tuned = {
            "edge": result.tuned_edge,
            "bar": given_edges[result.tuned_edge].tolist(),
            "given": result.tuned_stiffness[0],
            "stiffness": result.tuned_stiffness[1],
            "sensitivity": result.sensitivity,
            "scaled_sensitivity": result.scaled_sensitivity,
        }
    return {
        "response": "elastic",
        "frame": frame_body(result.frame),
        "stiffness": result.stiffness.tolist(),
        "displacement": result.response.tolist(),
        "report": {
            "source": list(result.source_pair),
            "target": list(result.target_pair),
            "requested_strain_ratio": result.ratio,
            "strain_ratio": result.strain_ratio,
            "ratio_error": result.ratio_error,
            "initial_strain_ratio": result.initial_ratio,
            "removed_edges": list(result.removed_edges),
            "removed_bars": given_edges[list(result.removed_edges)].reshape(-1, 2).tolist(),
            "tuned": tuned,
            "changes": result.changes,
            "max_stiffness": result.max_stiffness,
            "softest_mode_ratio": result.softest_mode,
            "timings_ms": dict(result.timings_ms),
        },
    }


# ----------------------------------------------------------------------------- finite motion


def _singularity(s) -> dict:
    return {
        "step": s.step,
        "parameter": s.parameter,
        "extra_zero_modes": s.extra_zero_modes,
        "sigma": s.sigma,
        "kind": s.kind,
    }


def motion_body(
    path: MotionPath,
    timings_ms: dict | None = None,
    strains=None,
    aimed: AimedMotion | None = None,
    curve: FidelityCurve | None = None,
) -> dict:
    """/v1/motion; ``strains`` (ε (P, 2), secant ν (P,)) of a lattice's configurations, or None;
    ``aimed``: the motion aimed at a target (its ``path`` is ``path``; in a refusal, ``reached``
    is the nearest value found); ``curve``: ε along the path for the linear target, or None."""
    body = {
        "path": path.positions.tolist(),
        "parameter": path.parameter.tolist(),
        "reference_index": path.reference_index,
        "max_relative_bar_error": path.max_relative_bar_error,
        "singularities": [_singularity(s) for s in path.singularities],
        "singular_start": None if path.singular_start is None else _singularity(path.singular_start),
        "status": path.status,
        "steps": int(len(path.parameter) - 1),
        "method": path.method,
    }
    if timings_ms is not None:
        body["timings_ms"] = timings_ms
    if strains is not None:
        body["strains"] = strains[0].tolist()
        body["poisson_ratio"] = [None if not np.isfinite(v) else float(v) for v in strains[1]]
    if aimed is not None:
        end = aimed.range_end or (None, None)
        body["target"] = {
            "kind": aimed.target.kind,
            "value": aimed.target.value,
            "reached": aimed.reached,
            "error": aimed.error,
            "index": aimed.index,
            "parameter": float(path.parameter[aimed.index]),
            "range_end": end[0],
            "range_end_reason": end[1],
        }
    if curve is not None:
        body["epsilon_curve"] = json_safe(
            {
                "amplitudes": curve.amplitudes.tolist(),
                "epsilon": curve.epsilon.tolist(),
                "parameter": curve.parameter.tolist(),
                "at_end": curve.at_end.tolist(),
            }
        )
    return body


def refinement_body(r) -> dict:
    """/v1/refine (and report.refinement of /v1/design); null for non-finite numbers."""
    return json_safe(
        {
            "frame": frame_body(r.frame),
            "displacement": r.displacement.tolist(),
            "amplitude": r.amplitude,
            "epsilon_before": r.epsilon_before,
            "epsilon_after": r.epsilon_after,
            "ipopt_status": r.ipopt_status,
            "iterations": r.iterations,
            "K": r.K,
            "attempts": r.attempts,
            "time_ms": r.time_ms,
            "ipopt_time_ms": r.ipopt_time_ms,
            "path": r.path.tolist(),
            "max_relative_bar_error": r.max_relative_bar_error,
            "analysis_reference": None
            if r.analysis_reference is None
            else counts_body(r.analysis_reference),
            "analysis_end": None if r.analysis_end is None else counts_body(r.analysis_end),
            "status": "ok" if r.ok else "refinement_failed",
            "message": r.message,
            "modes": None if r.mode is None else [r.mode.tolist()],
            "epsilon_curve": None
            if r.curve_before is None
            else {
                "amplitudes": r.curve_before.amplitudes.tolist(),
                "before": r.curve_before.epsilon.tolist(),
                "after": r.curve_after.epsilon.tolist(),
            },
        }
    )


# ----------------------------------------------------------------------------- certificates


def lmi_body(solution: LmiSolution | None) -> dict | None:
    if solution is None:
        return None
    return {
        "solver": solution.solver,
        "status": solution.status,
        "time_ms": solution.time_ms,
        "size": int(solution.x.size),
        "attempts": [
            {"solver": a.solver, "status": a.status, "time_ms": a.time_ms} for a in solution.attempts
        ],
    }


def self_stress_body(c: SelfStressCertificate) -> dict:
    return {
        "count": c.count,
        "basis": c.basis.tolist(),
        "basis_included": c.basis_included,
        "singular_values": {"smallest_nonzero": c.smallest_nonzero, "largest_zero": c.largest_zero},
        "equilibrium_residual": c.equilibrium_residual,
    }


def _field_body(value):
    """One dataclass field on the wire: an array as lists, an SDP solution as its record."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, LmiSolution):
        return lmi_body(value)
    return value


def fields_body(result) -> dict:
    """A certificate whose wire fields are its dataclass fields, in order (prestress, margin)."""
    return {f.name: _field_body(getattr(result, f.name)) for f in fields(result)}


def certificate_body(c: Certificate) -> dict:
    return {
        "analysis": counts_body(c.analysis),
        "self_stress": self_stress_body(c.self_stress),
        "prestress": fields_body(c.prestress),
        "rigidity_margin": fields_body(c.rigidity_margin),
        "timings_ms": dict(c.timings_ms),
    }


# ----------------------------------------------------------------------------- tolerance

# How the tolerance report names its quantities and errors in sentences.
QUANTITY_WORDS = {
    "mode": "the designed motion",
    "poisson_ratio": "the Poisson ratio",
    "target_response": "the target response",
    "rigidity_margin": "the rigidity margin",
    "mode_stiffness": "the mechanism's energy",
}


def _percent(v: float) -> str:
    return f"{100 * v:.2g} %"


def _tolerance_statement(e: ToleranceEstimate, report: ToleranceReport) -> str:
    """One estimate as a sentence: the tolerance, what it keeps, and what the Monte Carlo found."""
    what = QUANTITY_WORDS[e.quantity]
    errors = "bar lengths" if e.error == "bar_lengths" else "pin positions"
    if e.tolerance is None:
        return f"{what[0].upper()}{what[1:]} does not change to first order with errors in {errors}."
    size = _percent(e.tested_error)
    if e.error == "pin_positions":
        size += f" of the mean bar length (±{e.tested_error * report.mean_bar_length:.3g})"
    keeps = (f"below {_percent(e.predicted)} of the rigidity margin (mean)" if e.quantity == "mode_stiffness"
             else f"within {_percent(e.predicted)} (RMS)")
    capped = " (the largest error considered)" if e.tested_error < e.tolerance else ""
    sentence = f"{errors[0].upper()}{errors[1:]} within ±{size}{capped} keep {what} {keeps}"
    if e.monte_carlo is None:
        return sentence + f"; no perturbed frame could be assembled ({e.failed} of {report.samples})."
    found = f"a Monte Carlo of {report.samples} perturbed frames gives {_percent(e.monte_carlo)}"
    if e.agrees:
        return sentence + f"; {found}."
    failed = f", and {e.failed} could not be assembled" if e.failed else ""
    return sentence + f" by the linear estimate, which does not hold here: {found}{failed}."


def tolerance_body(report: ToleranceReport) -> dict:
    """report.tolerance of /v1/design: every estimate with its sentence, the tightest tolerance
    per kind of error, a summary and the estimates the Monte Carlo does not confirm."""
    estimates = []
    for e in report.estimates:
        body = {f.name: getattr(e, f.name) for f in fields(e)}
        body["tolerance_absolute"] = (
            None if e.tolerance is None or e.error != "pin_positions" else e.tolerance * report.mean_bar_length
        )
        body["statement"] = _tolerance_statement(e, report)
        estimates.append(body)
    tightest = {
        error: min((e.tolerance for e in report.estimates if e.error == error and e.tolerance is not None), default=None)
        for error in ("bar_lengths", "pin_positions")
    }
    parts = []
    if tightest["bar_lengths"] is not None:
        parts.append(f"bar lengths within ±{_percent(tightest['bar_lengths'])}")
    if tightest["pin_positions"] is not None:
        pins = tightest["pin_positions"]
        parts.append(f"pins within ±{_percent(pins)} of the mean bar length (±{pins * report.mean_bar_length:.3g})")
    summary = (
        f"Build {' and '.join(parts)} to keep every quantity within {_percent(report.budget)} (linear estimate)."
        if parts else "No quantity changes to first order with fabrication errors."
    )
    return json_safe({
        "budget": report.budget,
        "samples": report.samples,
        "seed": report.seed,
        "agreement_factor": report.agreement_factor,
        "mean_bar_length": report.mean_bar_length,
        "self_stresses": report.self_stresses,
        **tightest,
        "summary": summary,
        "disagreements": [b["statement"] for b in estimates if b["agrees"] is False],
        "estimates": estimates,
    })


def _iso(t: float | None) -> str | None:
    return None if t is None else datetime.fromtimestamp(t, UTC).isoformat(timespec="milliseconds")


def job_body(record: dict) -> dict:
    """GET /v1/jobs/{id}: a job record of the store (service/jobs/store.py) on the wire."""
    return {
        "id": record["id"],
        "endpoint": record["endpoint"],
        "status": record["status"],
        "progress": record["progress"],
        "message": record["message"],
        "result": record.get("result") if record["status"] == "done" else None,
        "error": record.get("error"),
        "created": _iso(record["created"]),
        "started": _iso(record["started"]),
        "finished": _iso(record["finished"]),
        "attempts": record["attempts"],
    }


def job_json(record: dict) -> bytes:
    """GET /v1/jobs/{id} as bytes, for a record whose ``result`` is the stored JSON text: the
    result is spliced in as stored, never decoded and encoded again (a lookup stays a few ms
    whatever the result's size)."""
    body = job_body({**record, "result": None})
    result = record.get("result") if record["status"] == "done" else None
    head = json.dumps({k: v for k, v in body.items() if k != "result"}, separators=(",", ":"))
    return (head[:-1] + ',"result":' + (result or "null") + "}").encode()


def sweep_point_body(record: dict) -> dict:
    return {
        "point": record["point"],
        "params": record.get("params") or {},
        "status": record["status"],
        "seq": record["seq"],
        "result": record.get("result") if record["status"] == "done" else None,
        "error": record.get("error"),
    }


def sweep_body(sweep: dict, finished_points: list[dict], after: int) -> dict:
    """GET /v1/sweeps/{id}: counts by state, and the finished points after the cursor."""
    counts = sweep["counts"]
    n = {state: counts.get(state, 0) for state in ("done", "failed", "running", "queued", "cancelled", "interrupted")}
    ended = n["done"] + n["failed"] + n["cancelled"] + n["interrupted"]
    if ended >= sweep["total"]:
        status = "cancelled" if sweep["cancelled"] else "done"
    else:
        status = "running"
    return {
        "id": sweep["id"],
        "endpoint": sweep["endpoint"],
        "status": status,
        "total": sweep["total"],
        **n,
        "progress": ended / sweep["total"],
        "created": _iso(sweep["created"]),
        "finished": _iso(sweep["finished"]),
        "results": [sweep_point_body(p) for p in finished_points],
        "next": finished_points[-1]["seq"] if finished_points else after,
    }


def multistable_body(result, timings_ms: dict) -> dict:
    """/v1/design/multistable for a MultistableDesign: the rods, the springs, the energy along
    the motion, each minimum with its verification, and the report."""
    link, springs, land = result.linkage, result.springs, result.landscape
    frame = link.frame
    return {
        "frame": frame_body(frame),
        "conformations": link.conformations.tolist(),
        "springs": {
            "pairs": springs.pairs.tolist(),
            "stiffness": springs.stiffness.tolist(),
            "rest_length": springs.rest_length.tolist(),
        },
        "landscape": {
            "arclength": land.arclength.tolist(),
            "energy": land.energy.tolist(),
            "conformation_samples": land.conformation_samples.tolist(),
            "positions": land.positions.tolist(),
        },
        "minima": [
            {
                "index": result.minimum_indices[m.index] if result.minimum_indices else m.index,
                "arclength": m.arclength,
                "energy": m.energy,
                "slope": m.slope,
                "curvature": m.curvature,
                "barrier_before": m.barrier_before,
                "barrier_after": m.barrier_after,
                "hessian_min_eigenvalue": c.hessian_min_eigenvalue,
                "relaxed_shift": c.relaxed_shift,
                "worst_landing": c.worst_landing,
            }
            for m, c in zip(land.minima, result.checks)
        ],
        "bifurcation": None if result.bifurcation is None else bifurcation_body(result),
        "report": {
            "construction": link.construction,
            "analysis": counts_body(link.analysis),
            "unspecified_nodes": frame.n_nodes - len(frame.specified),
            "rods": frame.n_edges,
            "springs": len(springs.pairs),
            "parameters": link.parameters.tolist(),
            "epsilons": link.epsilons.tolist(),
            "gap": link.gap,
            "max_length_mismatch": link.max_length_mismatch,
            "barrier": result.barrier,
            "max_stiffness": result.max_stiffness,
            "rod_stiffness_ratio": result.rod_stiffness_ratio,
            "relaxations": result.relaxations,
            "timings_ms": timings_ms,
        },
    }

def bifurcation_body(result) -> dict:
    """The branch point of a branched MultistableDesign: where it sits on the landscape, the
    rank drop, the stress and second-order form, both tangents and both continuations."""
    b, link = result.bifurcation, result.linkage
    first = link.parameters[result.minimum_indices[0]]
    followed = lambda f: {"reach": list(f.reach), "max_relative_bar_error": f.max_relative_bar_error, "separation": f.separation}
    return {
        "index": b.index,
        "arclength": float((link.parameters[b.index] - first) * link.arclength_scale),
        "energy": result.springs.energy(link.conformations[b.index]),
        "rank": b.point.rank,
        "sigma_kept": b.point.sigma_kept,
        "sigma_dropped": b.point.sigma_dropped,
        "stress": b.point.stress.tolist(),
        "form": list(b.point.form),
        "taken_tangent": b.taken_tangent.tolist(),
        "other_tangent": b.other_tangent.tolist(),
        "angle_degrees": b.point.angle,
        "dyad": list(b.dyad_nodes),
        "kind": b.dyad_kind,
        "taken_branch": followed(b.taken_branch),
        "other_branch": followed(b.other_branch),
    }


def module_map_body(the_map, at=()) -> dict:
    """/v1/map's body (without timings) for a solver ModuleMap: samples, range, fixed points and
    the exact values at ``at``."""
    end = lambda e: {"kind": e.kind, "d_in": e.d_in, "d_out": e.d_out}
    values, slopes = the_map.evaluate(np.asarray(at, dtype=float)) if len(at) else ([], [])
    module = the_map.module
    return {
        "input_pair": list(module.input_pair),
        "output_pair": list(module.output_pair),
        "d_in": the_map.d_in.tolist(),
        "d_out": the_map.d_out.tolist(),
        "slope": the_map.slope.tolist(),
        "lower": end(the_map.lower),
        "upper": end(the_map.upper),
        "fixed_points": [{"d": d, "slope": s, "stable": bool(abs(s) < 1)} for d, s in the_map.fixed_points()],
        "evaluated": [{"d_in": float(x), "d_out": float(v), "slope": float(s)} for x, v, s in zip(at, values, slopes)],
        "max_relative_bar_error": the_map.path.max_relative_bar_error,
    }


def map_response_body(the_map, at=()) -> dict:
    """/v1/map's body (without timings): module_map_body with the module's ``frame``, so that the
    answer alone draws and exports the module beside its map (documents.MAP)."""
    return {"frame": frame_body(the_map.module.frame), **module_map_body(the_map, at)}


def sequential_body(result, timings_ms: dict) -> dict:
    """/v1/design/sequential's body for a solver SequentialDesign (a SolitonDesign adds ``soliton``)."""
    from zeromode.solver.tolerances import MAP_RTOL

    design, verified = result.design, result.chain
    chain = None
    if verified is not None:
        chain = {
            "frame": frame_body(verified.chain.frame),
            "pairs": verified.chain.pairs.tolist(),
            "iterates": verified.chain.iterates.tolist(),
            "distances": verified.distances.tolist(),
            "path": verified.positions.tolist(),
            "reference_index": verified.reference_index,
            "deviation": verified.deviation,
            "iterate_deviation": verified.iterate_deviation,
            "ends": list(verified.ends),
        }
    module = design.module
    return {
        "module": {"frame": frame_body(module.frame), "input_pair": list(module.input_pair),
                   "output_pair": list(module.output_pair)},
        "map": module_map_body(design.map),
        "features": [
            {"d_in": p.d_in, "d_out": p.d_out, "slope": p.slope, "achieved_d_out": float(v), "achieved_slope": float(s)}
            for p, v, s in zip(design.points, design.achieved, design.slopes)
        ],
        "chain": chain,
        "soliton": soliton_body(result.soliton) if hasattr(result, "soliton") else None,
        "deviation": design.deviation,
        "map_rtol": MAP_RTOL,
        "solver_status": design.solver_status,
        "timings_ms": timings_ms,
    }


def soliton_body(soliton) -> dict:
    """The ``soliton`` part of /v1/design/sequential's body for a solver Soliton: springs, uniform
    states, drive, wall (its fractional index and its point on the chain), energy, snapshots
    (the chain's conformations are the chain's ``path``)."""
    module = soliton.module

    def uniform(k: int, fixed) -> dict:
        return {"d": fixed[0], "slope": fixed[1], "energy": float(soliton.uniform_energy[k]),
                "hessian_min_eigenvalue": float(soliton.uniform_hessian[k]), "positions": soliton.uniform[k].tolist()}

    return json_safe({
        "module": {"frame": frame_body(module.frame), "input_pair": list(module.input_pair),
                   "output_pair": list(module.output_pair)},
        "anchor_bar": list(soliton.anchor_bar),
        "spring_node": soliton.spring_node,
        "springs": {"pairs": soliton.springs.pairs.tolist(), "stiffness": soliton.springs.stiffness.tolist(),
                    "rest_length": soliton.springs.rest_length.tolist()},
        "unstable": uniform(0, soliton.unstable),
        "stable": uniform(1, soliton.stable),
        "drive": soliton.drive.tolist(),
        "rows": soliton.rows.tolist(),
        "wall": soliton.wall.tolist(),
        "wall_point": [c.tolist() if np.isfinite(w) else None for w, c in zip(soliton.wall, soliton.wall_point, strict=True)],
        "energy": soliton.energy.tolist(),
        "travel": soliton.travel,
        "required_travel": soliton.required_travel,
        "wall_slope": soliton.wall_slope,
        "predicted_wall_slope": -1.0 / float(np.log(soliton.unstable[1])),
        "barrier": soliton.barrier,
        "stiffness": soliton.stiffness,
        "rod_stiffness_ratio": soliton.rod_stiffness_ratio,
        "snapshots": soliton.snapshots.tolist(),
    })


def sequential_refusal_best(exc) -> dict | None:
    """The best figures of a refused sequential design (FeatureOutOfReach: the features as met
    and the module IPOPT ended with; chain_mismatch: the chain's deviation), else None."""
    best = getattr(exc, "best", None)
    if best is None:
        return None
    if hasattr(best, "points"):
        return json_safe({
            "features": [
                {"d_in": p.d_in, "d_out": p.d_out, "slope": p.slope, "achieved_d_out": float(v), "achieved_slope": float(s)}
                for p, v, s in zip(best.points, best.achieved, best.slopes)
            ],
            "deviation": best.deviation,
            "solver_status": best.solver_status,
            "positions": best.configurations[0].tolist(),
        })
    if hasattr(best, "soliton"):
        soliton = best.soliton
        return json_safe({
            "travel": soliton.travel, "required_travel": soliton.required_travel, "monotone": soliton.monotone,
            "hessian_min_eigenvalues": soliton.uniform_hessian.tolist(), "deviation": best.chain.deviation,
        })
    return json_safe({"deviation": best.deviation, "iterate_deviation": best.iterate_deviation})
