"""The one place that turns solver results into response bodies (the wire format).

Each function takes solver dataclasses (numpy inside) and returns the JSON-ready dict of one
response schema in service/schemas; routes, jobs and the CLI call these and nothing else
defines a body. Non-finite floats become null (JSON has no NaN) where a solver may produce
them: an IPOPT iterate that diverged.
"""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np

from zeromode.solver.certificates import (
    Certificate,
    LmiSolution,
    SelfStressCertificate,
)
from zeromode.solver.finite_motion import MotionPath
from zeromode.solver.frame import Frame
from zeromode.solver.rank import RankGap
from zeromode.solver.rigidity import Analysis

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
    return {"last_nonzero": gap.last_nonzero, "first_zero": gap.first_zero}


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


def auxetic_body(lattice, timings_ms: dict) -> dict:
    return {
        "frame": frame_body(lattice.frame),
        "modes": [lattice.mode.tolist()],
        "poisson_ratio": lattice.poisson_ratio,
        "states": [
            {"name": name, "positions": x.tolist(), "poisson_ratio": nu}
            for name, (x, nu) in sorted(lattice.states.items())
        ],
        "report": {
            "analysis": counts_body(lattice.analysis),
            "boundary": lattice.boundary,
            "mode_residual": lattice.mode_residual,
            "max_relative_bar_error": lattice.max_relative_bar_error,
            "timings_ms": timings_ms,
        },
    }


def allosteric_body(result, timings_ms: dict) -> dict:
    d = result.design
    return {
        "frame": frame_body(d.frame, specified=list(result.source) + list(result.target)),
        "modes": d.modes.tolist(),
        "report": {
            "analysis": counts_body(d.analysis),
            "source": list(result.source),
            "target": list(result.target),
            "relays": list(result.relays),
            "achieved_target_motion": result.achieved_target_motion.tolist(),
            "target_error": result.target_error,
            "distance": result.distance,
            "unspecified_nodes": d.frame.n_nodes - len(result.source) - len(result.target),
            "bars": d.frame.n_edges,
            "mode_residual": d.mode_residual,
            "timings_ms": timings_ms,
        },
    }


# ----------------------------------------------------------------------------- finite motion


def motion_body(path: MotionPath, timings_ms: dict | None = None) -> dict:
    body = {
        "path": path.positions.tolist(),
        "parameter": path.parameter.tolist(),
        "reference_index": path.reference_index,
        "max_relative_bar_error": path.max_relative_bar_error,
        "singularities": [
            {
                "step": s.step,
                "parameter": s.parameter,
                "extra_zero_modes": s.extra_zero_modes,
                "sigma": s.sigma,
                "kind": s.kind,
            }
            for s in path.singularities
        ],
        "status": path.status,
        "steps": int(len(path.parameter) - 1),
    }
    if timings_ms is not None:
        body["timings_ms"] = timings_ms
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
