"""Multistable design: a rods-and-springs network whose given conformations are strict local
minima of its elastic energy along one finite motion (beyond the seed paper; its published
version, Nature Physics 15, 714 (2019)).  The linkage (``linkage``), the springs (``springs``)
and the independent check of every minimum (``verify``); a result only when every check holds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.multistable.bifurcation import (
    Bifurcation,
    check_bifurcation,
    design_branched_linkage,
    minima_view,
)
from zeromode.solver.multistable.linkage import Linkage, check_conformations, design_linkage
from zeromode.solver.multistable.springs import Landscape, Springs, design_springs
from zeromode.solver.multistable.verify import (
    RELAXATIONS,
    ROD_STIFFNESS_RATIO,
    MinimumCheck,
    check_minima,
)
from zeromode.solver.progress import progress_stage


@dataclass(frozen=True, eq=False)
class MultistableDesign:
    """linkage: rods and the motion through the conformations; springs; landscape: the energy
    along the motion and each minimum; checks: the stiff-rod Hessian and relaxations per
    minimum; barrier, max_stiffness: what was asked for; bifurcation: the branch point when one
    was asked for (then that conformation is not a minimum: ``minimum_indices`` lists the
    conformations the landscape's minima and checks are of, in order)."""

    linkage: Linkage
    springs: Springs
    landscape: Landscape
    checks: tuple[MinimumCheck, ...]
    barrier: float
    max_stiffness: float
    rod_stiffness_ratio: float = ROD_STIFFNESS_RATIO
    relaxations: int = RELAXATIONS
    bifurcation: Bifurcation | None = None
    minimum_indices: tuple[int, ...] = ()


def design_multistable(
    conformations, barrier: float | None = None, max_stiffness: float = 1.0, dim: int | None = None, seed: int = 0,
    bifurcation: int | None = None,
) -> MultistableDesign:
    """Rods and springs through the conformations (C, k, d), C ∈ {2, 3}, each a strict minimum
    of E along the motion with barriers ≥ ``barrier`` (default: springs.DEFAULT_BARRIER_FRACTION of the largest
    barrier the springs can make)
    between neighbours and stiffnesses ≤ ``max_stiffness``.  With ``bifurcation`` (the index of
    one of three 2D conformations) the motion branches there (solver.multistable.bifurcation) and
    the springs make the other two the minima: a branch point has two first-order modes and is
    no minimum of E along the motion.  Refusals (DomainError): ``rigid_target``, ``no_linkage``,
    ``no_path``, ``no_bifurcation``, ``no_springs``, ``not_verified``."""
    if not (np.isfinite(max_stiffness) and max_stiffness > 0):
        raise InvalidInput("invalid_stiffness", "max_stiffness must be a positive number.")
    if barrier is not None and not (np.isfinite(barrier) and barrier > 0):
        raise InvalidInput("invalid_barrier", "barrier must be a positive number.")
    branch = None
    with progress_stage(0.0, 0.5, "linkage through the conformations"):
        if bifurcation is None:
            linkage = design_linkage(conformations, dim=dim, seed=seed)
        else:
            x = check_conformations(conformations, dim)
            check_bifurcation(bifurcation, x)
            linkage, branch = design_branched_linkage(x, bifurcation, seed=seed)
    minima = tuple(i for i in range(len(linkage.conformations)) if i != bifurcation)
    view = linkage if branch is None else minima_view(linkage, minima)
    with progress_stage(0.5, 0.8, "springs"):
        springs, landscape, barrier = design_springs(view, barrier, max_stiffness)
    with progress_stage(0.8, 1.0, "minima verified"):
        checks = check_minima(view.frame, view.conformations, springs, landscape, max_stiffness, seed=seed)
    low = [m for m in landscape.minima if m.barrier is not None and not m.barrier >= barrier]
    if low:
        raise DomainError(
            "not_verified",
            f"the barrier next to conformation {minima[low[0].index]} is {low[0].barrier:.4g}, below the {barrier:.4g} requested.",
        )
    failed = [c for c in checks if not c.ok]
    if failed:
        c = failed[0]
        raise DomainError(
            "not_verified",
            f"conformation {minima[c.index]} is not verified as a minimum of the rods-and-springs energy: smallest Hessian eigenvalue "
            f"{c.hessian_min_eigenvalue:.3g} (modulo rigid motions), relaxations land {c.worst_landing:.2e} away "
            f"({c.worst_landing_ratio:.2g} of the distance to the nearest other conformation).",
        )
    return MultistableDesign(
        linkage, springs, landscape, checks, float(barrier), float(max_stiffness), bifurcation=branch, minimum_indices=minima,
    )

