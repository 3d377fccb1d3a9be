"""Pictures of zeromode's results, from their arrays: a design, a lattice, an allosteric frame.

The mathematics comes from the solver: the rigid part of a mode is removed by
``rigidity.non_rigid_part`` and a state's boundary strain is ``boundary_strain.boundary_strains``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from zeromode.solver.analysis.rigidity import non_rigid_part
from zeromode.solver.frame import Frame
from zeromode.solver.motion.boundary_strain import boundary_strains
from zeromode.viz.picture import Picture
from zeromode.viz.style import MAX_ARROW_NODES

# Arrows per boundary side of a lattice with more than MAX_ARROW_NODES nodes.
ARROWS_PER_SIDE = 9
# The view (azimuth, elevation) of a 3D auxetic chain, whose blocks are strung along x: seen
# from nearly −y they stand side by side instead of overlapping along the default diagonal.
CHAIN_VIEW = (-82.0, 22.0)
# Lattice states, left to right around the reference.
STATE_ORDER = ("contracted", "reference", "expanded")


def design_picture(frame: Frame, modes, solution_space: bool = True) -> Picture:
    """A design (/v1/design): its modes, and their rows on the specified nodes as the requested
    motions (a design's modes equal them there); the solution space of each when asked and
    there are specified nodes."""
    modes = np.asarray(modes, dtype=float).reshape(-1, frame.n_nodes, frame.dim)
    return Picture.build(
        frame, modes=modes, targets=modes[:, list(frame.specified)],
        solution_space=solution_space and len(modes) > 0 and len(frame.specified) > 0,
    )


def lattice_picture(
    frame: Frame,
    modes,
    poisson_ratio: float,
    states: Mapping[str, tuple[np.ndarray, float]],
    boundary: Mapping[str, Sequence[int]] | None,
) -> Picture:
    """Contracted | reference (with the mode) | expanded, at one scale, each captioned: the
    reference with the mode's linear ν, a state with its boundary strain ε_x (when the boundary
    sets are known) and secant ν.  states: {name: (positions (N, d), ν)}.

    The mode is drawn modulo rigid motions (its part orthogonal to the d(d+1)/2 rigid-body
    motions): a zero mode plus a rigid motion is the same deformation, and the 3D chain's mode
    carries a large one.  A lattice of more than MAX_ARROW_NODES nodes carries arrows on
    ARROWS_PER_SIDE evenly spaced nodes of each boundary set, the sets whose motion defines
    ε_x, ε_y and ν (arrows on every node would hide the lattice).
    """
    modes = [non_rigid_part(frame.positions, m) for m in modes]
    names = [name for name in STATE_ORDER if name == "reference" or name in states]
    captions = []
    for name in names:
        if name == "reference":
            captions.append(f"mode: \u03bd = {_signed(poisson_ratio)}")
            continue
        x, nu = states[name]
        caption = f"\u03bd = {_signed(nu)}"
        if boundary:
            eps_x, _ = boundary_strains(frame.positions, np.asarray(x, dtype=float) - frame.positions, boundary)
            caption = f"\u03b5\u2093 = {_signed(eps_x)}, " + caption  # ε_x
        captions.append(caption)
    arrow_nodes = None
    if frame.n_nodes > MAX_ARROW_NODES and boundary:
        arrow_nodes = sorted({
            int(side[i])
            for side in boundary.values() if len(side)
            for i in np.unique(np.round(np.linspace(0, len(side) - 1, min(len(side), ARROWS_PER_SIDE))).astype(int))
        })
    return Picture.build(
        frame, modes=modes,
        configurations=[states[name][0] for name in names if name != "reference"],
        frame_panel=names.index("reference"), labels=names, captions=captions,
        arrow_nodes=arrow_nodes, **({"view": CHAIN_VIEW} if frame.dim == 3 else {}),
    )


def allosteric_picture(frame: Frame, modes, source: Sequence[int], target: Sequence[int], target_motion) -> Picture:
    """An allosteric frame: source and target sites marked, the mode as solid arrows and
    ``target_motion`` (k_tgt × d, rows in the order of ``target``; the prescribed or achieved
    one) as hollow arrows on the target nodes (zero rows, which draw nothing, elsewhere)."""
    motion = dict(zip(target, np.asarray(target_motion, dtype=float)))
    targets = [[motion.get(i, np.zeros(frame.dim)) for i in frame.specified]] if motion else None
    return Picture.build(frame, modes=modes, targets=targets, source=source, target_nodes=target)


def _signed(v: float) -> str:
    """A number with a typographic minus sign."""
    return f"{v:+.2f}".replace("-", "\u2212")
