"""The usable strain range of a lattice: [ε_min, ε_max] over which its exact finite motion stays
regular and physical, with the reason at each end.

A configuration of the motion is *usable* when
  * it is a regular point of the configuration space: the compatibility matrix C (paper Eq. 3)
    has the rank it has at the reference (a singular point — a branch point, or a point where
    the frame locks or flattens — ends the range);
  * no two nodes that share no bar are closer than PROXIMITY_FRACTION of the shortest bar (the
    joints of a built lattice have a size; two coinciding nodes are a collision);
  * in 2D, no node passes through a bar: the set of crossing bar pairs is that of the reference
    (bars may cross in the drawing of a planar linkage, on different layers, but a crossing that
    appears or disappears means a pin went through a bar).

2D sheets (module_range).  Every module of a sheet follows the same symmetric curve
(sheet_module.py), so every event of the sheet is an event of one module and its neighbours: a
node pair or a node–bar pair of the sheet is a translate of a pair between the module at (0, 0)
and a module at offset (i, j), |i| ≤ k_x, |j| ≤ k_y (needed_reach).  Conversely a pair of the
patch is a pair of the n_x × n_y sheet only if the sheet has modules holding both: each node
belongs to the modules that share it (a corner to four, another node to its own), a bar to the
modules holding both its ends, and a pair with owners o, o' (some choice among them) is a
translate of a pair of the sheet iff |o − o'| ≤ (n_x − 1, n_y − 1) componentwise.  The patch
watches exactly those (Patch.of): on a sheet two modules wide, a node of the neighbour at
(−1, j) and a bar of the neighbour at (+1, j') — two columns apart — are no pair of the sheet,
and at its edges a module has no neighbour beyond.  The watched pairs are then the sheet's own,
up to translation, at every size.  The scan follows the module's
curve outward from ε = 0 in steps of SCAN_STEP (Newton at every strain, exact to round-off) and
watches, as signed continuous functions of ε whose sign change is the event:
  * det[Ĉ(X); T(X)ᵀ] with Ĉ the module's C with unit rows (2N − 4 rows: the modules have no
    self-stress) and T = (x- and y-translations, the rotation, dX/dε), nonzero exactly where
    C has full row rank and T spans its null space — a simple singular point changes its sign
    (the vanishing singular value of C changes sign, as in finite_motion's bordered test);
    det J_U (sheet_module.py) likewise, where the strain stops parametrising the curve;
  * |X_p − X_q|/ℓ_min − PROXIMITY_FRACTION for each pair without a bar;
  * the signed area (X_r − X_q) × (X_p − X_q) of each node p and bar (q, r) not incident to it,
    an event where it changes sign with p between q and r.
A bracketed event is located by Brent's method to STRAIN_XTOL.  The cost is independent of the
number of cells; lattice.py measures the states on the full sheet (bar lengths, the closest
pair without a bar).

3D chains (chain_range).  The chain's finite motion is traced by continuation
(finite_motion.trace_motion) both ways until a singular point (located there), a node pair
closer than the threshold, a turning point of the strain along the motion, or |ε| =
MAX_SCAN_STRAIN; the range ends at the last traced configuration before a proximity or turning
event (so every configuration inside it was examined).  Bar crossings are not watched in 3D
(bars are segments in space; two of them meet only on a set of codimension one, not an event
the motion crosses generically).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import cKDTree

from zeromode.solver.applications.sheet_module import SymmetricModule
from zeromode.solver.errors import DomainError
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import trace_motion
from zeromode.solver.progress import report_detail
from zeromode.solver.tolerances import FOLD_XTOL, PROXIMITY_FRACTION, STRAIN_XTOL

# The scan examines strains up to this magnitude (a sheet stretched by 90 % or compressed to a
# tenth of its length is far beyond any design here); beyond, the range is "search_limit".
MAX_SCAN_STRAIN = 0.9
# Step of the 2D scan in strain; events are bracketed between steps and located to STRAIN_XTOL.
SCAN_STEP = 0.01
# Patches by (module topology, reach, cells seen): see Patch.of.
_PATCHES: dict = {}
# Step of the 3D chain's continuation (finite_motion's path parameter) while the range is scanned.
CHAIN_MAX_STEP = 0.01

REASONS = {
    "singular_point": "the compatibility matrix loses rank (a singular point of the finite motion)",
    "node_proximity": f"two nodes without a bar come closer than {PROXIMITY_FRACTION:g} of the shortest bar",
    "bar_crossing": "a node passes through a bar",
    "strain_extremum": "the strain reaches an extremum along the motion (beyond, it turns back)",
    "search_limit": f"the motion stays usable up to the largest strain examined (|ε| = {MAX_SCAN_STRAIN:g})",
}


@dataclass(frozen=True)
class RangeEnd:
    """One end of the usable range: the strain ε_x, the reason (a key of REASONS) and a sentence
    naming what happens there."""

    strain: float
    reason: str
    detail: str


@dataclass(frozen=True)
class StrainRange:
    """[lower.strain, upper.strain] ∋ 0; ``shortest_bar`` ℓ_min of the reference."""

    lower: RangeEnd
    upper: RangeEnd
    shortest_bar: float
    proximity_fraction: float = PROXIMITY_FRACTION

    def contains(self, strain: float) -> bool:
        return self.lower.strain <= strain <= self.upper.strain

    def describe(self) -> str:
        """'[−0.43, +0.081] (below: …; above: …)'."""
        return (
            f"[{self.lower.strain:+.6g}, {self.upper.strain:+.6g}] "
            f"(at {self.lower.strain:+.6g}: {self.lower.detail}; at {self.upper.strain:+.6g}: {self.upper.detail})"
        )


# ----------------------------------------------------------------------------------------------
# 2D: one module and its neighbours


@dataclass(frozen=True, eq=False)
class Patch:
    """The module at (0, 0) and the copies around it that can touch it: patch node n is module
    node ``node[n]`` of the copy at ``offset[n]`` (shared corners once); ``bars`` every bar of
    the patch; ``pairs`` node pairs to watch (one end in module (0, 0), no bar between them);
    ``node_bar`` (node, bar) pairs to watch (the node or the bar in module (0, 0), the node not
    on the bar); both only those that are pairs of the sheet of ``cells`` modules (the module
    docstring).  ``reach`` (k_x, k_y): the largest offsets included."""

    node: np.ndarray
    offset: np.ndarray
    bars: np.ndarray
    pairs: np.ndarray
    node_bar: np.ndarray
    reach: tuple[int, int]

    @classmethod
    def of(cls, module: SymmetricModule, reach: tuple[int, int], cells: tuple[int, int]) -> Patch:
        """The patch of ``module`` with copies up to ``reach``, watching the pairs of an
        n_x × n_y sheet (``cells``); it depends on the module's topology only (corners are told
        apart on the normalised lattice), so it is cached.  Owners of a watched pair are at most
        k + 1 modules apart along each axis (one end, or a bar's end, in module (0, 0)), so every
        n ≥ k + 2 watches the same pairs."""
        seen = tuple(int(min(c, r + 2)) for c, r in zip(cells, reach))
        key = (module.kinds, module.edges.tobytes(), module.orbit.tobytes(), reach, seen)
        if key not in _PATCHES:
            _PATCHES[key] = cls._build(module, reach, seen)
        return _PATCHES[key]

    @classmethod
    def _build(cls, module: SymmetricModule, reach: tuple[int, int], cells: tuple[int, int]) -> Patch:
        offsets = [(0, 0)] + [
            (i, j) for i in range(-reach[0], reach[0] + 1) for j in range(-reach[1], reach[1] + 1) if (i, j) != (0, 0)
        ]
        # Nodes are told apart on the reference integer lattice of half-cells: corners sit on
        # it, and a copy's corner k at offset o is the corner of its neighbours it coincides with.
        x0 = module.positions(module.reference) / module.reference[:2]
        node, offset, index, local, owners = [], [], {}, {}, []
        for o in offsets:
            for k, p in enumerate(x0 + 2 * np.asarray(o)):
                key = ("corner", *np.rint(p).astype(int)) if k < 4 else (o, k)
                if key not in index:
                    index[key] = len(node)
                    node.append(k)
                    offset.append(o)
                    # The modules holding it: a corner (odd lattice point P) is corner of the
                    # four modules centred at P ± (1, 1) (offsets (P ± 1)/2), another node its own.
                    owners.append(
                        {((key[1] + sx) // 2, (key[2] + sy) // 2) for sx in (-1, 1) for sy in (-1, 1)}
                        if k < 4 else {o}
                    )
                local[(o, k)] = index[key]
        to_patch = {o: np.array([local[(o, k)] for k in range(module.n_nodes)]) for o in offsets}
        bars = np.unique(np.sort(np.vstack([to_patch[o][module.edges] for o in offsets]), axis=1), axis=0)
        m = len(node)
        own = np.unique(to_patch[(0, 0)])
        mine = np.zeros(m, dtype=bool)
        mine[own] = True
        # Pairs with one end in module (0, 0) and no bar, as codes lo·m + hi (each once).
        lo_hi = np.sort(np.column_stack([np.repeat(own, m), np.tile(np.arange(m), len(own))]), axis=1)
        codes = np.setdiff1d(lo_hi[:, 0] * m + lo_hi[:, 1], bars[:, 0] * m + bars[:, 1])
        codes = codes[codes // m != codes % m]
        pairs = np.column_stack([codes // m, codes % m])
        p_all, b_all = np.meshgrid(np.arange(len(node)), np.arange(len(bars)), indexing="ij")
        p_all, b_all = p_all.ravel(), b_all.ravel()
        q_all, r_all = bars[b_all, 0], bars[b_all, 1]
        keep = (p_all != q_all) & (p_all != r_all) & (mine[p_all] | mine[q_all] | mine[r_all])
        node_bar = np.column_stack([p_all[keep], b_all[keep]])
        # A bar belongs to the modules holding both its ends (the module's edges are closed
        # under its mirrors, so each of them has it).
        node_owners = _owner_array(owners)
        bar_owners = _owner_array([owners[q] & owners[r] for q, r in bars])
        pairs = pairs[_realised(node_owners[pairs[:, 0]], node_owners[pairs[:, 1]], cells)]
        node_bar = node_bar[_realised(node_owners[node_bar[:, 0]], bar_owners[node_bar[:, 1]], cells)]
        return cls(
            np.array(node), np.array(offset, dtype=float), bars,
            pairs.astype(int).reshape(-1, 2), node_bar.astype(int).reshape(-1, 2), reach,
        )

    def positions(self, module: SymmetricModule, q: np.ndarray) -> np.ndarray:
        return module.positions(q)[self.node] + self.offset * (2 * q[:2])


def _owner_array(owners: list[set]) -> np.ndarray:
    """(n, 4, 2) integer offsets of each element's owning modules (at most four: a corner's),
    padded by repeating the first."""
    rows = [sorted(o) for o in owners]
    return np.array([r + [r[0]] * (4 - len(r)) for r in rows], dtype=int).reshape(-1, 4, 2)


def _realised(a: np.ndarray, b: np.ndarray, cells: tuple[int, int]) -> np.ndarray:
    """(P,) whether pair p, with owners a[p] (P, 4, 2) and b[p], is a translate of a pair of the
    n_x × n_y sheet: some owners o ∈ a[p], o' ∈ b[p] with |o − o'| ≤ (n_x − 1, n_y − 1)."""
    gap = np.abs(a[:, :, None, :] - b[:, None, :, :])  # (P, 4, 4, 2)
    fits = (gap[..., 0] <= cells[0] - 1) & (gap[..., 1] <= cells[1] - 1)
    return fits.any(axis=(1, 2))


def needed_reach(module: SymmetricModule, q: np.ndarray, shortest: float, cells: tuple[int, int]) -> tuple[int, int]:
    """The largest offsets (k_x, k_y) at which a copy can touch module (0, 0) at q: copies k
    apart overlap when 2k·a ≤ 2·(their half-extent) + the proximity distance; at most the
    sheet's own n − 1."""
    x = np.abs(module.positions(q))
    margin = PROXIMITY_FRACTION * shortest
    return tuple(
        int(min(cells[axis] - 1, np.floor((2 * x[:, axis].max() + margin) / (2 * q[axis]))))
        for axis in (0, 1)
    )


def _regularity(module: SymmetricModule, q: np.ndarray) -> tuple[float, float]:
    """(det[Ĉ; Tᵀ], det J_U) at q: see the module docstring; both change sign at a simple
    singular point of the module's motion, det J_U also where the strain turns back."""
    x = module.positions(q)
    e = module.edges
    d = x[e[:, 0]] - x[e[:, 1]]
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    n = module.n_nodes
    c = np.zeros((len(e), 2 * n))
    rows = np.arange(len(e))
    for k in range(2):
        c[rows, 2 * e[:, 0] + k] = d[:, k]
        c[rows, 2 * e[:, 1] + k] = -d[:, k]
    jac_u = module.jacobian(q)[:, 1:]
    try:
        tangent = module.positions(module.tangent(q))
    except np.linalg.LinAlgError:
        return 0.0, 0.0
    size = np.sqrt(np.mean(np.sum(x * x, axis=1)))
    gens = [np.tile([1.0, 0.0], n), np.tile([0.0, 1.0], n), np.column_stack([-x[:, 1], x[:, 0]]).ravel() / size]
    gens.append(tangent.ravel() / max(np.linalg.norm(tangent), 1e-300))
    return float(np.linalg.det(np.vstack([c, np.array(gens) / np.sqrt(n)]))), float(np.linalg.det(jac_u))


def _events(module: SymmetricModule, patch: Patch, q: np.ndarray, shortest: float) -> dict[str, np.ndarray]:
    """Every watched function at q (see the module docstring), by kind."""
    x = patch.positions(module, q)
    gap = np.linalg.norm(x[patch.pairs[:, 0]] - x[patch.pairs[:, 1]], axis=1) / shortest - PROXIMITY_FRACTION
    p, b = patch.node_bar[:, 0], patch.node_bar[:, 1]
    qa, qb = x[patch.bars[b, 0]], x[patch.bars[b, 1]]
    along, rel = qb - qa, x[p] - qa
    area = (along[:, 0] * rel[:, 1] - along[:, 1] * rel[:, 0]) / np.sum(along * along, axis=1)
    t = np.sum(rel * along, axis=1) / np.sum(along * along, axis=1)
    singular = np.array(_regularity(module, q))
    return {"singular_point": singular, "node_proximity": gap, "bar_crossing": area, "projection": (t >= 0) & (t <= 1)}


def _event(module: SymmetricModule, patch: Patch, q: np.ndarray, shortest: float, kind: str, k: int) -> float:
    """Watched function k of ``kind`` at q alone (as _events, without the others)."""
    if kind == "singular_point":
        return _regularity(module, q)[k]
    x = patch.positions(module, q)
    if kind == "node_proximity":
        p, r = patch.pairs[k]
        return float(np.linalg.norm(x[p] - x[r]) / shortest - PROXIMITY_FRACTION)
    p, b = patch.node_bar[k]
    qa, qb = x[patch.bars[b, 0]], x[patch.bars[b, 1]]
    along, rel = qb - qa, x[p] - qa
    return float((along[0] * rel[1] - along[1] * rel[0]) / np.dot(along, along))


def _inside(module: SymmetricModule, patch: Patch, q: np.ndarray, k: int) -> bool:
    """Whether node–bar pair k has its node between the bar's ends (projection in [0, 1])."""
    x = patch.positions(module, q)
    p, b = patch.node_bar[k]
    qa, qb = x[patch.bars[b, 0]], x[patch.bars[b, 1]]
    t = float(np.dot(x[p] - qa, qb - qa) / np.dot(qb - qa, qb - qa))
    return 0.0 <= t <= 1.0


@dataclass(frozen=True, eq=False)
class ModuleMotion:
    """The module's symmetric motion over its usable range: samples (strain (S,), q (S, n_q)),
    ascending in strain with ε = 0 among them, and the range."""

    module: SymmetricModule
    strains: np.ndarray
    configurations: np.ndarray
    range: StrainRange

    def at(self, strain: float) -> np.ndarray:
        """q at ε = ``strain`` (inside the range): tangent predictor and Newton (as the scan
        advanced) from the nearest sample, else from the next nearest. Both are within one scan
        step; the nearest alone can fail where the motion is steep and that sample is a range
        end located past the last scanned step (ν = −57: Newton from the end at ε = −0.0077
        missed ε = −0.0039, which the sample at 0 reaches)."""
        for k in np.argsort(np.abs(self.strains - strain), kind="stable")[:2]:
            q = _advance(self.module, self.configurations[k], float(self.strains[k]), strain)
            if q is not None:
                return q
        raise DomainError(
            "not_converged", f"no configuration of the module's motion was found at strain {strain:g}."
        )


def module_range(
    module: SymmetricModule,
    cells: tuple[int, int],
    limits: tuple[float, float] | None = None,
    xtol: float = STRAIN_XTOL,
    max_reach: int | None = None,
) -> ModuleMotion:
    """The usable range of the n_x × n_y sheet (``cells``) tiled from ``module``, and the
    module's motion sampled over it.  The patch of copies watched grows with the nodes' reach
    (needed_reach) as the scan goes.  ``limits`` (lo < 0 < hi): scan no further than these
    strains (an end there is "search_limit"); default ±MAX_SCAN_STRAIN.  xtol: how precisely an
    event is located in strain (a search that only compares ranges needs less than round-off).
    max_reach: watch copies no farther than this many modules along each axis (the cost stays
    that of a (max_reach + 1)² sheet; the caller checks the full sheet); the pairs watched are
    still those of the n_x × n_y sheet."""
    lo_limit, hi_limit = limits if limits is not None else (-MAX_SCAN_STRAIN, MAX_SCAN_STRAIN)
    shortest = float(np.sqrt(np.min(module.squared_lengths)))
    q0 = module.reference
    patches = {}
    # needed_reach caps the reach at n − 1; max_reach caps it further.
    reach_cells = cells if max_reach is None else tuple(min(c, max_reach + 1) for c in cells)

    def patch_for(reach):
        if reach not in patches:
            patches[reach] = Patch.of(module, reach, cells)
        return patches[reach]

    ends, samples = [], {0.0: q0}
    for sign in (1.0, -1.0):
        eps, q = 0.0, q0
        patch = patch_for(needed_reach(module, q0, shortest, reach_cells))
        prev = _events(module, patch, q0, shortest)
        end = None
        while end is None:
            limit = hi_limit if sign > 0 else -lo_limit
            target = sign * min(abs(eps) + SCAN_STEP, limit)
            q_next = _advance(module, q, eps, target)
            if q_next is None:
                end = _stalled(module, q, eps, target)
                # An event between the last sample and the fold comes first.
                q_end = _advance(module, q, eps, end.strain)
                if q_end is not None:
                    now = _events(module, patch, q_end, shortest)
                    end = _first_event(module, patch, prev, now, q, eps, end.strain, shortest, xtol) or end
                break
            reach = tuple(max(r, s) for r, s in zip(patch.reach, needed_reach(module, q_next, shortest, reach_cells)))
            if reach != patch.reach:
                patch = patch_for(reach)
                prev = _events(module, patch, q, shortest)
            now = _events(module, patch, q_next, shortest)
            end = _first_event(module, patch, prev, now, q, eps, target, shortest, xtol)
            if end is not None:
                break
            eps, q, prev = target, q_next, now
            samples[eps] = q
            # Progress (a building block: into a stage opened for it): each direction half.
            report_detail(0.5 * (sign < 0) + 0.5 * abs(eps) / limit, "scanning the module's motion")
            if abs(eps) >= limit:
                detail = REASONS["search_limit"] if limits is None else f"the scan stopped at the requested strain {eps:+g}"
                end = RangeEnd(eps, "search_limit", detail)
        ends.append(end)
        if end.strain not in samples:
            q_end = module.configuration(end.strain, q + (end.strain - eps) * module.tangent(q))
            if q_end is not None:
                samples[end.strain] = q_end
    strains = np.array(sorted(samples))
    return ModuleMotion(
        module,
        strains,
        np.array([samples[s] for s in strains]),
        StrainRange(lower=ends[1], upper=ends[0], shortest_bar=shortest),
    )


def _advance(module: SymmetricModule, q: np.ndarray, eps: float, target: float):
    """q at ``target`` from q at ``eps``: tangent predictor, Newton corrector (None if it fails)."""
    try:
        guess = q + (target - eps) * module.tangent(q)
    except np.linalg.LinAlgError:
        return None
    return module.configuration(target, guess)


def _stalled(module: SymmetricModule, q: np.ndarray, eps: float, target: float) -> RangeEnd:
    """Newton failed between eps and target: the curve stops being a graph over the strain (a
    singular point of the symmetric motion); located by bisection on Newton's success."""
    lo, hi, q_lo = eps, target, q
    while abs(hi - lo) > FOLD_XTOL:
        mid = 0.5 * (lo + hi)
        q_mid = _advance(module, q_lo, lo, mid)
        if q_mid is None:
            hi = mid
        else:
            lo, q_lo = mid, q_mid
    return RangeEnd(lo, "singular_point", "the module's motion cannot be continued beyond this strain: " + REASONS["singular_point"])


def _first_event(module, patch, prev, now, q, eps, target, shortest, xtol=STRAIN_XTOL) -> RangeEnd | None:
    """The event closest to ``eps`` among the sign changes between two samples, located."""
    best = None
    for kind in ("singular_point", "node_proximity", "bar_crossing"):
        changed = np.flatnonzero(np.sign(prev[kind]) != np.sign(now[kind]))
        if kind == "bar_crossing":
            # A node that changes sides of a bar's line beyond the bar's ends crosses nothing.
            changed = [k for k in changed if prev["projection"][k] or now["projection"][k]]
        for k in changed:
            def f(s, kind=kind, k=k):
                q_s = module.configuration(s, q + (s - eps) * module.tangent(q))
                if q_s is None:
                    return np.nan
                return _event(module, patch, q_s, shortest, kind, k)

            try:
                root = brentq(f, eps, target, xtol=xtol)
            except ValueError:
                root = target
            if kind == "bar_crossing":
                q_root = module.configuration(root, q + (root - eps) * module.tangent(q))
                if q_root is None or not _inside(module, patch, q_root, k):
                    continue
            if best is None or abs(root - eps) < abs(best[0] - eps):
                best = (root, kind, k)
    if best is None:
        return None
    root, kind, k = best
    return RangeEnd(float(root), kind, _detail(module, patch, kind, k))


def _detail(module: SymmetricModule, patch: Patch, kind: str, k: int) -> str:
    def name(n: int) -> str:
        o = patch.offset[n]
        where = "" if not o.any() else f" of the neighbour at ({int(o[0]):+d}, {int(o[1]):+d})"
        return f"module node {int(patch.node[n])}{where}"

    if kind == "node_proximity":
        p, q = patch.pairs[k]
        return f"{name(p)} and {name(q)} come closer than {PROXIMITY_FRACTION:g} of the shortest bar"
    if kind == "bar_crossing":
        p, b = patch.node_bar[k]
        q, r = patch.bars[b]
        return f"{name(p)} passes through the bar between {name(q)} and {name(r)}"
    return REASONS["singular_point"]


# ----------------------------------------------------------------------------------------------
# 3D: the chain's own continuation


@dataclass(frozen=True, eq=False)
class ChainMotion:
    """A chain's traced motion over its usable range: strains (P,) ascending, positions (P, N, 3)
    aligned to the reference, and the range."""

    strains: np.ndarray
    positions: np.ndarray
    range: StrainRange


def chain_range(frame: Frame, mode: np.ndarray, strain_of) -> ChainMotion:
    """The usable range of a chain's motion, ``strain_of(X)`` its ε_x at a configuration X.

    The motion is traced both ways (finite_motion.trace_motion, steps ≤ CHAIN_MAX_STEP) and each
    direction stops at the first configuration where two nodes without a bar come closer than
    PROXIMITY_FRACTION·ℓ_min, where ε_x turns back (it stops parametrising the motion), where
    |ε_x| ≥ MAX_SCAN_STRAIN, or at a singular point (located by the continuation).  The end is
    the last configuration before a proximity or turning event (every configuration inside was
    examined; the event lies within one step beyond), the singular point itself, or the search
    limit."""
    lengths = np.linalg.norm(frame.positions[frame.edges[:, 0]] - frame.positions[frame.edges[:, 1]], axis=1)
    shortest = float(lengths.min())
    joined = {tuple(sorted(e)) for e in frame.edges.tolist()}
    seen = {1: [0.0], -1: [0.0]}
    events = {}

    def stop(x, sign):
        eps = float(strain_of(x))
        close = [p for p in cKDTree(x).query_pairs(PROXIMITY_FRACTION * shortest) if tuple(sorted(p)) not in joined]
        history = seen[sign]
        if close:
            events[sign] = RangeEnd(history[-1], "node_proximity", f"nodes {close[0][0]} and {close[0][1]} come closer than {PROXIMITY_FRACTION:g} of the shortest bar within one step beyond this strain")
            return True
        if len(history) > 1 and (eps - history[-1]) * (history[-1] - history[-2]) <= 0:
            events[sign] = RangeEnd(history[-1], "strain_extremum", REASONS["strain_extremum"])
            return True
        history.append(eps)
        if abs(eps) >= MAX_SCAN_STRAIN:
            events[sign] = RangeEnd(eps, "search_limit", REASONS["search_limit"])
            return True
        return False

    path = trace_motion(frame, mode, amplitude=2 * MAX_SCAN_STRAIN, max_step=CHAIN_MAX_STEP, direction="both", stop=stop)
    strains = np.array([strain_of(x) for x in path.positions])
    ends = {}
    for sign, side in ((1, slice(path.reference_index, None)), (-1, slice(None, path.reference_index + 1))):
        if sign in events:
            ends[sign] = events[sign]
        else:  # a singular point (the path stops on it) or the parameter limit
            way = strains[side] * sign
            last, extreme = float(way[-1] if sign == 1 else way[0]), float(way.max())
            singular = any(np.sign(s.parameter) == sign for s in path.singularities)
            reason = "singular_point" if singular else "search_limit"
            if extreme > last:  # ε_x turned back within the last step (onto the singular point)
                reason = "strain_extremum"
            ends[sign] = RangeEnd(sign * extreme, reason, REASONS[reason])
    lo, hi = sorted((ends[1], ends[-1]), key=lambda e: e.strain)
    keep = (strains >= lo.strain) & (strains <= hi.strain)
    order = np.argsort(strains[keep])
    return ChainMotion(strains[keep][order], path.positions[keep][order], StrainRange(lower=lo, upper=hi, shortest_bar=shortest))
