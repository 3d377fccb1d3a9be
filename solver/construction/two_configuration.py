"""Finite two-configuration design: a frame whose specified nodes can be at x_S and at y_S with
every bar keeping its length (beyond the seed paper; its published version designs frames from
initial and final positions).

An unspecified node at p (first configuration) and q (second) keeps its bar to specified node i
iff ‖x_i − p‖² = ‖y_i − q‖².  With midpoints m = (x + y)/2, half-differences h = (y − x)/2 and
m_U = (p + q)/2, h_U = (q − p)/2 this reads

    ‖(m_i − m_U) − (h_i − h_U)‖² = ‖(m_i − m_U) + (h_i − h_U)‖²  ⇔  (m_i − m_U)·(h_i − h_U) = 0,

the paper's bar constraint (Eq. 1) for positions m and motions h (the averaging principle of
rigidity theory).  So the finite problem is the infinitesimal design of ``design`` for the
specified set (m_S, h_S), and every designed node gives p = m_U − h_U, q = m_U + h_U: both
configurations are exact realisations with equal bar lengths.  A finite rigid motion y = Rx + t
maps to an infinitesimal rigid motion of m (Cayley transform), which ``design`` refuses.

Whether one continuous motion carries the first configuration to the second is a separate
question: it is checked by continuation (``finite_motion.motion_fidelity``) and reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.rigidity import Analysis, analyze
from zeromode.solver.construction.design import Design, design
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.solver.motion.finite_motion import motion_fidelity
from zeromode.solver.progress import progress_stage
from zeromode.solver.tolerances import REACHED_EPS


@dataclass(frozen=True, eq=False)
class TwoConfigurationDesign:
    """One frame realising two configurations of its specified nodes, x_S and y_S.

    Attributes
    ----------
    frame : Frame
        The first configuration (specified nodes first, at x_S exactly).
    final_positions : np.ndarray
        (N, d): the second configuration (y_S first, exactly).
    midpoint : Design
        The infinitesimal design it comes from (at (x_S + y_S)/2, motion (y_S − x_S)/2).
    analysis_initial : Analysis
        The first configuration's analysis.
    max_length_mismatch : float
        The largest relative difference of a bar's length between the configurations.
    epsilon : float or None
        Finite-motion fidelity ε of the traced motion from the first configuration towards y_S
        (None if it could not be traced).
    path_note : str
        One sentence on that motion: reached, on another branch, or why it was not traced.
    """

    frame: Frame
    final_positions: np.ndarray
    midpoint: Design
    analysis_initial: Analysis
    max_length_mismatch: float
    epsilon: float | None
    path_note: str


def design_two_configurations(initial, final, dim: int | None = None, seed: int = 0) -> TwoConfigurationDesign:
    """Design a frame realising both x_S (``initial``) and y_S (``final``), each (k, d)."""
    x = check_positions(initial, dim, "initial")
    y = check_positions(final, x.shape[1], "final")
    if x.shape != y.shape:
        raise InvalidInput("invalid_shape", f"final must have one row per specified node ({len(x)}), got {len(y)}.")
    k = len(x)
    try:
        with progress_stage(0.0, 0.2, "design"):  # progress: the design, then the traced motion
            mid = design(0.5 * (x + y), 0.5 * (y - x), seed=seed)
    except DomainError as exc:
        if exc.code == "rigid_target":
            raise DomainError(
                "rigid_target", "the final configuration is a rigid motion of the initial one (or equal to it)."
            ) from None
        raise
    centre, half = mid.frame.positions, mid.modes[0]
    first, second = centre - half, centre + half
    first[:k], second[:k] = x, y  # exact, not rounded through the midpoint
    frame = Frame.build(first, mid.frame.edges, specified=range(k))
    e = frame.edges
    l1 = np.linalg.norm(first[e[:, 0]] - first[e[:, 1]], axis=1)
    l2 = np.linalg.norm(second[e[:, 0]] - second[e[:, 1]], axis=1)
    mismatch = float(np.max(np.abs(l2 - l1) / l1))
    analysis = analyze(frame)
    epsilon, note = None, "the first configuration has exactly one nontrivial mode"
    if analysis.nontrivial_zero_modes != 1 or analysis.self_stresses:
        note = (
            f"the first configuration has {analysis.nontrivial_zero_modes} nontrivial modes and "
            f"{analysis.self_stresses} self-stresses, so no single motion was traced"
        )
    else:
        try:
            with progress_stage(0.2, 1.0, "the motion between them"):
                fid, _ = motion_fidelity(frame, y - x)
            epsilon = fid.epsilon
            note = "continuation from the first configuration reaches the second" if epsilon <= REACHED_EPS else (
                "the two configurations lie on different branches (or beyond a singular point): "
                "no continuous motion was found between them; /v1/refine can repair the path"
            )
        except DomainError as exc:
            note = f"continuation failed: {exc.message}"
    return TwoConfigurationDesign(frame, second, mid, analysis, mismatch, epsilon, note)
