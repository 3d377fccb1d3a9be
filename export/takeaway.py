"""What leaves zeromode: a frame, what it does, and what was said about it.

A Takeaway is the neutral content every export writes in its own format: the frame's nodes and
bars (its rods), springs beside them (a multistable design's: pairs, stiffness k_s, rest length
L_s of E = Σ k_s (ℓ_s − L_s)²/2; an element type of their own, never a rod), the role of each
node (specified or unspecified; source, target or relay of an allosteric design, input and
output pair of a chain), its zero modes, a finite motion (configurations with their path
parameter, aligned to the reference: the rigid motion removed by a Kabsch step,
solver.finite_motion.align_to, unless the configurations are placed by the user, as a
multistable design's conformations are), named further configurations (a lattice's states, a
multistable design's conformations) and metadata (numbers and sentences of the report).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from zeromode.solver.errors import InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import align_to
from zeromode.viz.picture import stacked

# Sites of a node, as exported (point data "site" in VTK, attribute "site" in graphs).
SITES = ("none", "source", "target", "relay")


@dataclass(frozen=True, eq=False)
class SpringSet:
    """Springs as exported: pairs (S, 2) node indices, stiffness (S,) k_s > 0, rest_length (S,)
    L_s ≥ 0, of E = Σ k_s (ℓ_s − L_s)²/2 (the fields of solver.multistable.springs.Springs, kept
    here so that exports do not import the spring design's cone-program solver)."""

    pairs: np.ndarray
    stiffness: np.ndarray
    rest_length: np.ndarray


@dataclass(frozen=True, eq=False)
class Takeaway:
    """frame: the Frame (N nodes, N_B bars: the rods); modes (M, N, d); path (T, N, d) with
    parameter (T,) and reference_index (the input configuration), or None; configurations:
    {name: (N, d)}; source, target, relays: node indices of an allosteric design's sites (a
    chain's input and output pairs); springs: S springs (pairs (S, 2), stiffness (S,),
    rest_length (S,); S = 0 without); metadata: JSON-ready mapping (the document's kind and
    report, a tolerance report, units)."""

    frame: Frame
    modes: np.ndarray
    path: np.ndarray | None = None
    parameter: np.ndarray | None = None
    reference_index: int = 0
    configurations: Mapping[str, np.ndarray] = field(default_factory=dict)
    source: tuple[int, ...] = ()
    target: tuple[int, ...] = ()
    relays: tuple[int, ...] = ()
    metadata: Mapping = field(default_factory=dict)
    springs: SpringSet = field(default_factory=lambda: no_springs())

    @classmethod
    def build(
        cls,
        frame: Frame,
        modes=None,
        path=None,
        parameter=None,
        reference_index: int | None = None,
        configurations: Mapping[str, Sequence] | None = None,
        source: Sequence[int] = (),
        target: Sequence[int] = (),
        relays: Sequence[int] = (),
        metadata: Mapping | None = None,
        springs: SpringSet | None = None,
        align: bool = True,
    ) -> Takeaway:
        """Check shapes against the frame (InvalidInput ``invalid_shape`` naming the field),
        check the springs (checked_springs) and align every configuration of the path to the
        reference one (Kabsch: a finite motion is defined modulo rigid motions, so each
        configuration is shown in the pose nearest the frame's; ``align`` False keeps them where
        they are given, as a multistable design's conformations, whose specified nodes the user
        placed). The reference is ``reference_index`` (default: the configuration with parameter
        0, else the first)."""
        n, d = frame.n_nodes, frame.dim
        modes = stacked(modes, n, d, "modes", "the frame's nodes")
        traced = stacked(path, n, d, "path", "the frame's nodes")
        t = None
        ref = 0
        if len(traced):
            t = np.arange(len(traced), dtype=float) if parameter is None else np.asarray(parameter, dtype=float)
            if t.shape != (len(traced),):
                raise InvalidInput("invalid_shape", f"parameter has {t.size} values for {len(traced)} configurations.")
            ref = int(np.argmin(np.abs(t))) if reference_index is None else int(reference_index)
            if not 0 <= ref < len(traced):
                raise InvalidInput("invalid_shape", f"reference_index {ref} is outside 0..{len(traced) - 1}.")
            if align:
                traced = np.stack([align_to(x, frame.positions) for x in traced])
        else:
            traced = None
        configs = {
            name: stacked([x], n, d, f"configurations.{name}", "the frame's nodes")[0]
            for name, x in (configurations or {}).items()
        }
        for name, nodes in (("source", source), ("target", target), ("relays", relays)):
            if any(not 0 <= int(i) < n for i in nodes):
                raise InvalidInput("invalid_nodes", f"{name} names a node outside 0..{n - 1}.")
        return cls(
            frame, modes, traced, t, ref, configs,
            tuple(int(i) for i in source), tuple(int(i) for i in target), tuple(int(i) for i in relays),
            dict(metadata or {}), checked_springs(frame, springs),
        )

    @property
    def specified_mask(self) -> np.ndarray:
        """(N,) bool: the specified nodes V_S."""
        mask = np.zeros(self.frame.n_nodes, bool)
        mask[list(self.frame.specified)] = True
        return mask

    @property
    def sites(self) -> np.ndarray:
        """(N,) int: index into SITES of each node (0 none, 1 source, 2 target, 3 relay)."""
        site = np.zeros(self.frame.n_nodes, int)
        for code, nodes in ((1, self.source), (2, self.target), (3, self.relays)):
            site[list(nodes)] = code
        return site

    @property
    def lengths(self) -> np.ndarray:
        """(N_B,) bar lengths of the reference configuration."""
        x, e = self.frame.positions, self.frame.edges
        return np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1)


    @property
    def spring_lengths(self) -> np.ndarray:
        """(S,) the springs' lengths ℓ_s in the reference configuration (not their rest lengths)."""
        x, p = self.frame.positions, self.springs.pairs
        return np.linalg.norm(x[p[:, 0]] - x[p[:, 1]], axis=1)


def no_springs() -> SpringSet:
    """A frame of rods only: S = 0."""
    return SpringSet(np.zeros((0, 2), dtype=int), np.zeros(0), np.zeros(0))


def checked_springs(frame: Frame, springs: SpringSet | None) -> SpringSet:
    """The springs as arrays (no_springs for None), or InvalidInput ``invalid_springs`` naming
    the first fault: shapes that differ, a node outside the frame, a spring joining a node to
    itself, on a rod's pair or on another spring's (exports keep the two element types apart,
    and a graph has one edge per pair), a stiffness not > 0, a rest length not ≥ 0."""
    if springs is None:
        return no_springs()
    pairs = [tuple(int(i) for i in pair) for pair in np.asarray(springs.pairs, dtype=object).reshape(-1, 2)]
    stiffness = np.asarray(springs.stiffness, dtype=float).reshape(-1)
    rest = np.asarray(springs.rest_length, dtype=float).reshape(-1)

    def refuse(sentence: str):
        raise InvalidInput("invalid_springs", sentence)

    if not len(pairs) == len(stiffness) == len(rest):
        refuse(f"springs have {len(pairs)} pairs, {len(stiffness)} stiffnesses and {len(rest)} rest lengths.")
    n = frame.n_nodes
    taken = {frozenset(e) for e in frame.edges.tolist()}
    for s, (i, j) in enumerate(pairs):  # Python ints: a node number beyond int64 is named, not overflowed
        if not (0 <= i < n and 0 <= j < n) or i == j:
            refuse(f"spring {s} joins [{i}, {j}]: two distinct nodes of 0..{n - 1} are needed.")
        if frozenset((i, j)) in taken:
            refuse(f"spring {s} joins [{i}, {j}], which a rod or an earlier spring already joins.")
        taken.add(frozenset((i, j)))
    if not np.all(np.isfinite(stiffness) & (stiffness > 0)):
        refuse("every spring's stiffness must be finite and > 0.")
    if not np.all(np.isfinite(rest) & (rest >= 0)):
        refuse("every spring's rest length must be finite and ≥ 0.")
    return SpringSet(np.array(pairs, dtype=int).reshape(-1, 2), stiffness, rest)
