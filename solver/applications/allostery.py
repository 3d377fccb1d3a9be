"""Allosteric response by a chain of coupled modules (paper, Fig. 5e–g: "long-range coupled
conformational regulation"; "Combining Networks Through Judicious Constraint Placement").

A source site (nodes x_src moving with u_src) must drive a distant target site (nodes x_tgt)
through a prescribed motion u_tgt: the designed frame's only nontrivial zero mode has rows
u_src and u_tgt exactly, so driving the source moves the target as prescribed, to linear order.

Construction, in canonical coordinates (``Similarity``: source centroid at the origin, the axis
to the target centroid along e_1, lengths in units of the site size, motions in units of the
source's RMS motion), so that every choice is free of translation, rotation and scale:
  * ports — relay sites laid along the axis: in 2D a rung of 2 nodes across the axis stretched
    along itself, in 3D a triangle across the axis dilated in its plane (each motion non-rigid
    on its port, which is all a port needs). From each site the ports grow geometrically, size
    a_{j+1} = g·a_j, one module length λ·a_j apart, until they meet in the middle;
  * modules — each pair of consecutive ports (or a site and a port) is joined by unspecified
    nodes placed on solution spaces (hierarchy.place_module): the port nearer its own site is
    tied to the frame built so far, so the union keeps exactly one nontrivial zero mode and no
    self-stress (argument in hierarchy's docstring). The ports' motions are chosen, not fitted:
    nothing is approximated, so the mode is exact at any distance;
  * the growth modules are similar copies of one module (port 1 → port g at distance λ), designed
    once; with g > 1 a distance D needs O(log_g D) modules, the small modules sit only next to
    the sites, and the response's sensitivity to node positions (measured in site units) stays
    bounded instead of adding up over D/a identical relays;
  * the ports' motions grow with their size (constant strain), or (robust chains, the default)
    all have the amplitude PORT_AMPLITUDE: relays of gain 1, so no relay carries a motion, and
    an angle error, larger than the sites'.
Sites closer than two module lengths are joined directly by one design (design.design).

Every answer carries its accuracy (target error, from the frame's own zero modes), the
relative singular-value gap of the designed mode, the linear sensitivity of the response and
the amplification of fabrication errors a builder feels (``ResponseFigures``). An answer with
target error above TARGET_ERROR_MAX or gap below GAP_FLOOR is not returned: by default the
chains of ROBUST_CHAINS are all designed, the best of them is rebuilt with the source modules
of smallest lever (``source_tilt``, screened over the first port at each of SOURCE_SIDES and the
source site's base of REACHES), and the acceptable one with the smallest amplification is
kept; then (or with robustness="economy" first) other port sizes, growths, module lengths and
seeds are tried (``ALTERNATIVES``) and, if none meets both, DomainError ``inaccurate_design``
reports the best.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from zeromode.solver.analysis.eigen import smallest_eigenpairs
from zeromode.solver.analysis.factorisation import cholesky
from zeromode.solver.analysis.normalisation import Normalisation, rms_radius, unit_scaled
from zeromode.solver.analysis.rank import orthonormal_range
from zeromode.solver.analysis.rigidity import compatibility_matrix, rigid_motions
from zeromode.solver.budget import check_budget
from zeromode.solver.construction.design import (
    Design,
    check_motions_nonrigid,
    check_specified_distinct,
    design,
    verify,
)
from zeromode.solver.construction.hierarchical_placement import (
    Module,
    module_gap,
    place_module,
    tied_space,
)
from zeromode.solver.construction.placement import target_zero_modes
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.solver.motion.finite_motion import bar_lengths
from zeromode.solver.progress import progress_scope, progress_stage, report_progress
from zeromode.solver.tolerances import (
    AXES_RTOL,
    DISTINCT_RTOL,
    GAP_FLOOR,
    SENSITIVITY_PERTURBATION,
    TARGET_ERROR_MAX,
)

# A chain of more modules is refused before any work (too_expensive): ~1 ms per module copy, but
# the frame's analysis and figures grow with it; 400 modules is ~1600 nodes in 2D.
MAX_MODULES = 400
# Default ports: the first is DEFAULT_PORT site sizes across; they grow by DEFAULT_GROWTH per
# module; a module is DEFAULT_ASPECT times its smaller port long.
DEFAULT_PORT, DEFAULT_GROWTH, DEFAULT_ASPECT = 2.0, 2.0, 1.0
# Sites whose facing fronts are closer than this many first-port lengths are designed directly.
DIRECT_GAP = 2.0
# Robust chains' ports all move with this amplitude (canonical units: the source's RMS motion),
# whatever their size: relays of gain 1. Ports whose motion grows with their size (constant
# strain, ChainOptions.amplitude None: the economy chains, whose shape sensitivity stays flat) carry
# motions up to D/2 in the middle of a long chain, and every relay's angle error, proportional
# to its strain rate × its node error, reached the target through a lever of the remaining
# distance: measured (bench_allostery, amplification), gain 1 brought the 2D amplification at
# D = 200 from 733 to 300 (worst of three sites), 3D at D = 96 from 1415 to 593.
PORT_AMPLITUDE = 1.0
# Above this many bars the response and the figures use sparse factorisations instead of dense
# matrices (a dense least-squares solve of 400 bars takes ~20 ms, of 1500 ~0.5 s).
DENSE_MAX_BARS = 400


@dataclass(frozen=True)
class ChainOptions:
    """port: size of the first port next to each site (site units); growth g ≥ 1; aspect λ:
    module length per smaller-port size; seed of the module placements; amplitude: every port's
    motion amplitude (canonical units; relays of gain 1), or None for motions growing with the
    port's size (constant strain); source_side: where the source site's first port sits, a
    (twist, offset) of SOURCE_SIDES (as SIDE_VARIANTS: see Side), or None for the variant of
    SIDE_VARIANTS with the best gap; reach: 0, or the source site's chain leaves from a base
    (``source_base``) this fraction of the gap between the sites away (REACHES)."""

    port: float = DEFAULT_PORT
    growth: float = DEFAULT_GROWTH
    aspect: float = DEFAULT_ASPECT
    seed: int = 0
    amplitude: float | None = None
    source_side: tuple[float, float] | None = None
    reach: float = 0.0


# The alternatives tried, in order, when an answer misses the floors (fields a caller fixed
# through relay_spacing / relay_growth are kept).
ALTERNATIVES = (
    {},
    {"seed": 1},
    {"aspect": 0.75},
    {"aspect": 1.5},
    {"port": 1.0},
    {"port": 4.0},
    {"growth": 1.5},
    {"growth": 3.0},
    {"seed": 2, "aspect": 1.25},
)


# robustness="robust" (the default): these chains are all designed (fields a caller fixed are
# kept) and the acceptable one with the smallest amplification A is returned; measured
# (benchmarks/bench_allostery.py), A depends on the chain erratically — a lever near the source
# site, where errors of ℓ̄ meet the smallest modules — so a search beats any single rule. Ports in
# site sizes; growth 1 lays equal relays; longer modules (aspect 1.5 … 3) often did best, and
# the sites joined directly (DIRECT_PORT: no relay fits) gave A ∝ D, best of all near D ≈ 100
# site sizes in 2D. robustness="economy": the first acceptable of ALTERNATIVES (fewest nodes).
DIRECT_PORT = 1e3
ROBUST_CHAINS = (
    *(
        {"port": port, "growth": growth, "amplitude": PORT_AMPLITUDE}
        for port in (2.0, 4.0, 8.0, 16.0)
        for growth in (1.0, 1.5, 2.0)
    ),
    *(
        {"port": port, "growth": growth, "aspect": aspect, "amplitude": PORT_AMPLITUDE}
        for port in (4.0, 8.0)
        for growth in (1.0, 1.5)
        for aspect in (1.5, 2.0, 3.0)
    ),
    {"port": DIRECT_PORT},
)
# Robust candidates needing more modules than this are skipped (equal small relays across a long
# distance: hundreds of nodes, each relay adding to the lever; 3D designs of 200 nodes took 20 s).
ROBUST_MAX_MODULES = 16
ROBUSTNESS = ("robust", "economy")
# Then the acceptable chain of smallest A is rebuilt with the source site's first
# port at each of SOURCE_SIDES (ChainOptions.source_side) and the smallest A is kept. Measured
# (docs/benchmarks/allostery.md, profile of ∂w_T/∂x by node): in 3D almost all of A (95–99 %) is
# the target's rigid motion driven by node errors in the source site's module — the angle at which
# the chain leaves the source, carried to the target by a lever of length D — and where that
# module's port sits decides it: over these placements A of one chain spread from 37 to 620
# (3D, D = 12) and from 350 to 70 000 (D = 48), while the best gap (the old choice) picked 151
# and 583. In 2D a port has no twist; only the offsets differ. Only the best chain: then the
# chain an answer reports (port, growth, seed) designs that answer again, since among the chains
# with its port and growth the same one is best. Refining the best two did better on some sites
# (3D, D = 48, shape 2: A 357 against 414) but then a re-posted chain could pick another answer.
# Since the chain beyond the source module only carries the port's motion (its rigid part
# rigidly, to the target: ``source_tilt``), each placement is screened on the source module alone
# (one module, ~10 ms in 3D) and only the REFINED_BUILDS placements of smallest tilt are built
# whole; measured (3D, D = 48, shape 2, the chain of port 2, growth 1) the screen ranks as the
# whole frames do (tilt 249, 347, 875, 5035 for A 232–414, 293–492, 517–573, 4088–4687).
SOURCE_SIDES = tuple(
    (turn, shift) for turn in (0.0, 1 / 6, 1 / 3, 1 / 2, 2 / 3, 5 / 6) for shift in (0.0, 0.25, -0.25, 0.5, -0.5)
)
# Source bases tried (ChainOptions.reach, fractions of the gap between the sites; 0: none) and
# how many screened source sides of each are built whole (the screen ranks the source side; the
# rest of the frame, and ℓ̄, which the base's long bars raise, still decide some answers).
# Measured (3D, sampled worst of four): D = 48 shape 2, chain (2, 1, 1): best of 3 built 396
# without a base, 102 at reach 0.3; D = 96 shape 1: 85 at 0.2, 76 at 0.3, 107 at 0.45; D = 200
# shape 1: 93 at 0.2, 137 at 0.3, 126 at 0.45 (the floors 200, 283, 408). A fourth reach (0.55)
# or twice the builds changed nothing on the one site still above its floor (D = 200, shape 2).
# In 2D the base lowered the reported A but not the sampled worst of four (D = 96, shape 2:
# A 171 → 124, sampled 144 → 313), and 2D met its floors without it: 2D chains leave the site.
REACHES = (0.0, 0.25, 0.4)
REFINED_BUILDS = 2


@dataclass(frozen=True, eq=False)
class ResponseFigures:
    """How well a frame does what it was designed for.

    achieved_target_motion (k_tgt, d): the target rows of the response to the source motion,
    solved from the frame's own zero modes (``response``); target_error: ‖achieved − u_tgt‖ /
    ‖u_tgt‖; gap: σ_min/σ_max of the unit compatibility matrix beyond the designed zero modes;
    sensitivity: the largest relative change of the target site's shape change (its motion
    modulo rigid motions of the site) when the nodes move by ``perturbation`` site sizes (all
    together, Euclidean norm, worst direction); motion_sensitivity: the same for the target's
    whole motion, rigid part included (grows with the distance: a lever). amplification: the
    builder's amplification A — the relative change of the target's whole motion per relative
    node error, every node moved by ε·ℓ̄ (ℓ̄ the mean bar length) in an independent uniformly
    random direction, root mean square over those errors; amplification_worst: the same ratio
    for the worst perturbation of RMS node error ε·ℓ̄ (an upper bound of every sampled A, to
    first order); amplification_top: A of the worst direction alone (its share of the RMS). See
    linear_figures.
    """

    achieved_target_motion: np.ndarray
    target_error: float
    gap: float
    sensitivity: float
    motion_sensitivity: float
    amplification: float
    amplification_worst: float
    amplification_top: float
    perturbation: float = SENSITIVITY_PERTURBATION

    def acceptable(self) -> bool:
        return self.target_error <= TARGET_ERROR_MAX and self.gap >= GAP_FLOOR

    def amplification_tail(self) -> float:
        """√(A² + 3 A_top²): the key by which designs are compared, for the worst of a few
        seeded errors, not their RMS. With one dominant direction (A_top ≈ A) a sample is A·|g|,
        g ~ N(0, 1), and the largest of four |g| is ~2; with many directions samples stay near A.
        Measured (bench_allostery): sampled worst of four / A rose to 2.3–2.7 on designs whose
        J is nearly of rank one (2D, D = 96, shape 2: A 122, sampled 334)."""
        return math.sqrt(self.amplification**2 + 3 * self.amplification_top**2)

    def rank(self) -> tuple:
        """Ordering key, best first: meets the floors, then error (to a decade), then gap."""
        return (not self.acceptable(), round(math.log10(max(self.target_error, 1e-300))), -self.gap)


@dataclass(frozen=True, eq=False)
class AllostericDesign:
    """An allosteric design from scratch and what it achieves.

    Attributes
    ----------
    design : Design
        The design; its frame's nodes are the source, then the target, then the relays and
        unspecified nodes.
    source, target : tuple of int
        The sites' node indices.
    relays : tuple of int
        The port nodes between the sites.
    figures : ResponseFigures
        What the design achieves: the target's response to the source motion and its errors.
    distance : float
        The distance between the sites' centroids, in the caller's units.
    modules : int
        How many modules the chain has (1 for a direct design).
    options : ChainOptions
        The chain parameters that produced it (port in site sizes).
    site_size : float
        The site size s in the caller's units (the canonical length).
    """

    design: Design
    source: tuple[int, ...]
    target: tuple[int, ...]
    relays: tuple[int, ...]
    figures: ResponseFigures
    distance: float
    modules: int
    options: ChainOptions
    site_size: float

    @property
    def achieved_target_motion(self) -> np.ndarray:
        """The target's rows of the response to the source motion (figures)."""
        return self.figures.achieved_target_motion

    @property
    def target_error(self) -> float:
        """The achieved target motion's error relative to the prescribed one (figures)."""
        return self.figures.target_error


class InaccurateDesign(DomainError):
    """No alternative met the floors; ``best`` holds the figures of the best attempt and
    ``options`` its chain options (None when every attempt failed to build); site_size as in
    AllostericDesign."""

    def __init__(self, message: str, best: ResponseFigures | None, options: ChainOptions | None, site_size: float):
        super().__init__("inaccurate_design", message)
        self.best = best
        self.options = options
        self.site_size = site_size


# ----------------------------------------------------------------------------- canonical frame


@dataclass(frozen=True)
class Similarity:
    """y = R(x − origin)/length, v = R u/speed: the canonical coordinates of a request.

    rotation R (d, d) has the canonical axes as rows: e_1 from the source to the target
    centroid, then axes chosen from the source site's shape (``_axes``)."""

    origin: np.ndarray
    rotation: np.ndarray
    length: float
    speed: float

    def positions_in(self, x: np.ndarray) -> np.ndarray:
        return (x - self.origin) @ self.rotation.T / self.length

    def positions_out(self, y: np.ndarray) -> np.ndarray:
        return self.origin + self.length * (y @ self.rotation)

    def motions_in(self, u: np.ndarray) -> np.ndarray:
        return u @ self.rotation.T / self.speed

    def motions_out(self, v: np.ndarray) -> np.ndarray:
        return self.speed * (v @ self.rotation)


def canonical(x_src: np.ndarray, u_src: np.ndarray, x_tgt: np.ndarray) -> Similarity:
    """The Similarity of a request: origin the source centroid, length the larger site's RMS
    radius, speed the source motion's RMS size, axes from ``_axes``."""
    length = max(rms_radius(x_src), rms_radius(x_tgt))
    y, m = unit_scaled(u_src)
    speed = m * float(np.sqrt(np.mean(np.sum(y**2, axis=1))))
    origin = x_src.mean(axis=0)
    axis = (x_tgt.mean(axis=0) - origin) / length
    return Similarity(origin, _axes(axis, (x_src - origin) / length, (x_tgt - origin) / length), length, speed)


def _axes(axis: np.ndarray, *clouds: np.ndarray) -> np.ndarray:
    """Orthonormal rows: e_1 = axis/|axis|, then (3D) the direction across the axis along which
    the first non-symmetric cloud spreads most (sign: positive third moment), then e_1 × e_2.

    Rotating the request rotates these axes with it, so canonical coordinates are rotation-free;
    only sites symmetric about the axis leave the choice to the coordinate axes."""
    d = len(axis)
    norm = float(np.linalg.norm(axis))
    e1 = axis / norm if norm > DISTINCT_RTOL else np.eye(d)[0]
    if d == 2:
        return np.array([e1, [-e1[1], e1[0]]])
    across = np.eye(3) - np.outer(e1, e1)
    for cloud in clouds:
        p = (cloud - cloud.mean(axis=0)) @ across
        values, vectors = np.linalg.eigh(p.T @ p)
        if values[2] - values[1] > AXES_RTOL * max(values[2], 1e-300):
            e2 = vectors[:, 2]
            skew = float(np.sum((p @ e2) ** 3))
            e2 = -e2 if skew < 0 else e2
            break
    else:
        e2 = across[np.argmin(np.abs(e1))]
        e2 = e2 / np.linalg.norm(e2)
    return np.array([e1, e2, np.cross(e1, e2)])


# ----------------------------------------------------------------------------- ports and plan


def port(
    d: int, t: float, size: float, mirrored: bool = False, amplitude: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """A port of ``size`` across the axis at e_1-coordinate t: positions and motion (p, d).

    2D: a rung (t, ±size/2), stretched along itself (motion ±a/2 · e_2).
    3D: an equilateral triangle of circumradius size/2 in the plane e_1 = t, dilated in its
    plane (motion = a × its offset from the axis per unit size). a = ``amplitude`` (the same at
    every size: relays of gain 1), or ``size`` when None (constant strain). Both motions are
    non-rigid on the port. ``mirrored`` reflects e_1 (ports built from the target side)."""
    if d == 2:
        offsets = np.array([[0.0, -0.5], [0.0, 0.5]])
    else:
        angles = 2 * np.pi * np.arange(3) / 3
        offsets = 0.5 * np.column_stack([np.zeros(3), np.cos(angles), np.sin(angles)])
    positions = size * offsets
    positions[:, 0] += t
    motion = (size if amplitude is None else amplitude) * offsets
    if mirrored:
        motion = motion * np.r_[-1.0, np.ones(d - 1)]
    return positions, motion


@dataclass(frozen=True)
class Plan:
    """Port positions along e_1 and sizes (site units): source side outward, target side
    outward (decreasing e_1)."""

    source_ports: tuple[tuple[float, float], ...]
    target_ports: tuple[tuple[float, float], ...]

    @property
    def modules(self) -> int:
        return len(self.source_ports) + len(self.target_ports) + 1


def estimated_modules(gap: float, options: ChainOptions) -> int:
    """Modules a chain across ``gap`` (site units) will need, before planning it: gap/(λa) for
    uniform ports, else two geometric sums Σ λ a gʲ reaching gap/2 each."""
    step = options.aspect * options.port
    if gap <= 0:
        return 1
    if options.growth == 1.0:
        return int(gap / step) + 1
    return 2 * int(math.log(1 + gap * (options.growth - 1) / (2 * step), options.growth)) + 3


def plan_chain(front_src: float, front_tgt: float, options: ChainOptions) -> Plan:
    """Ports between the sites' facing fronts (e_1-coordinates, site units).

    Each step adds a port on the side whose next port is smaller (source first on ties), one
    module length (λ × the previous port, or λ × the first port next to a site) beyond its
    front, g times the previous port (the first is ``options.port``), provided a module length
    λ·max(both fronts) still separates it from the other side; then one adapter module joins the
    two fronts. No port fits: the sites are joined directly."""
    a0, g, lam = options.port, options.growth, options.aspect
    sides = [[front_src, None, []], [front_tgt, None, []]]  # front, last size, ports
    direction = (1.0, -1.0)
    while True:
        check_budget()
        nxt = [a0 if s[1] is None else g * s[1] for s in sides]
        moved = False
        for i in sorted((0, 1), key=lambda i: nxt[i]):
            front, last, ports = sides[i]
            t = front + direction[i] * lam * (a0 if last is None else last)
            other_front, other_last, _ = sides[1 - i]
            room = (other_front - t) * direction[i]
            if room >= lam * max(nxt[i], a0 if other_last is None else other_last):
                ports.append((t, nxt[i]))
                sides[i][0], sides[i][1] = t, nxt[i]
                moved = True
                break
        if not moved:
            return Plan(tuple(sides[0][2]), tuple(sides[1][2]))


# ----------------------------------------------------------------------------- modules


@lru_cache(maxsize=64)
def growth_module(d: int, growth: float, aspect: float, seed: int, amplitude: float | None = None) -> Module:
    """The module from a tied port of size 1 at e_1 = 0 to a free port of size g at e_1 = λ
    (canonical units; with ``amplitude`` both move with it: gain 1), designed once and copied
    along every chain with these parameters."""
    x_a, u_a = port(d, 0.0, 1.0, amplitude=amplitude)
    x_b, u_b = port(d, aspect, growth, amplitude=amplitude)
    return _module((x_a, u_a, True), (x_b, u_b, False), seed)[0]


def _module(a, b, seed: int) -> tuple[Module, float]:
    """A module between node groups (positions, motion, tied) and its gap
    (hierarchy.module_gap): a tied group may move only as the frame built before it allows
    (hierarchy.tied_space), a free one in any way."""
    d = a[0].shape[1]
    null = sla.block_diag(*(tied_space(x, u) if tied else np.eye(x.size) for x, u, tied in (a, b)))
    target = target_zero_modes(d, 1)
    # Tried in loops (site variants, alternatives): the chain reports per module, not placement.
    with progress_scope(None):
        module = place_module(np.vstack([a[0], b[0]]), np.vstack([a[1], b[1]]), null, target, seed)
    return module, module_gap(module, null, target)


@dataclass(frozen=True)
class Side:
    """Where one side's ports sit: rotated by ``twist`` about e_1 and shifted across it by
    ``offset`` (site units along e_2) — a rigid motion, so growth copies stay valid — and
    reflected along e_1 on the target side (``mirrored``)."""

    mirrored: bool
    twist: float = 0.0
    offset: float = 0.0

    def rotation(self, d: int) -> np.ndarray:
        if d == 2:
            return np.eye(2)
        c, s = math.cos(self.twist), math.sin(self.twist)
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])

    def place(self, y: np.ndarray, v: np.ndarray, t: float = 0.0, scale: float = 1.0, gain_one: bool = False):
        """Canonical positions and motions of a port or module drawn at e_1 = 0 with size 1:
        scaled (positions only with ``gain_one``: the bar constraint is invariant under scaling
        either alone), reflected, rotated, then moved to e_1 = t and across by ``offset``."""
        d = y.shape[1]
        flip = np.r_[-1.0 if self.mirrored else 1.0, np.ones(d - 1)]
        r = self.rotation(d)
        shift = np.r_[t, self.offset, np.zeros(d - 2)]
        return (scale * y * flip) @ r.T + shift, ((1.0 if gain_one else scale) * v * flip) @ r.T


# Where the first port next to a site may sit (twist about e_1 in turns of the port's symmetry,
# offset across the axis in first-port sizes): the site module with the best gap is kept,
# stopping at the first one reaching SITE_GAP_GOOD.
SIDE_VARIANTS = ((0.0, 0.0), (1 / 3, 0.0), (2 / 3, 0.0), (0.0, 0.25), (0.0, -0.25), (1 / 2, 0.25))
SITE_GAP_GOOD = 1e-2


class _Assembly:
    """The chain's nodes and bars in canonical coordinates; given nodes of a module are merged
    with the nodes already there (same indices), its unspecified nodes appended."""

    def __init__(self, x: np.ndarray, u: np.ndarray):
        self.positions = [x]
        self.motions = [u]
        self.count = len(x)
        self.edges: list[np.ndarray] = []
        self.anchor_sets: list[tuple[int, ...]] = []

    def add_nodes(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        index = np.arange(self.count, self.count + len(x))
        self.positions.append(x)
        self.motions.append(u)
        self.count += len(x)
        return index

    def add_module(self, module: Module, given: np.ndarray, x: np.ndarray, u: np.ndarray) -> None:
        """Add a module whose given nodes are the nodes ``given`` and whose unspecified nodes
        sit at x (n, d) moving with u (n, d)."""
        new = self.add_nodes(x, u)
        edges = np.concatenate([given, new])[module.edges]
        self.edges.append(edges)
        for j in new:
            self.anchor_sets.append(tuple(sorted(edges[edges[:, 1] == j, 0].tolist())))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        edges = np.vstack(self.edges) if self.edges else np.zeros((0, 2), dtype=int)
        return np.vstack(self.positions), np.vstack(self.motions), edges


def _site_module(y, v, ports, mirrored: bool, options: ChainOptions):
    """The module from a site (free) to its first port (free): (Side, module, gap) of the best
    of SIDE_VARIANTS, or of the source side ``options.source_side`` when it is set."""
    d = y.shape[1]
    t, size = ports[0]
    x_unit, u_unit = port(d, 0.0, 1.0, amplitude=options.amplitude)
    gain_one = options.amplitude is not None
    best = None
    if options.source_side is not None and not mirrored:
        variants = [options.source_side]
    else:
        variants = SIDE_VARIANTS if d == 3 else [v for v in SIDE_VARIANTS if v[0] == 0.0]
    for turn, shift in variants:
        side = Side(mirrored, turn * 2 * math.pi / 3, shift * size)
        x_p, u_p = side.place(x_unit, u_unit, t, size, gain_one)
        try:
            module, gap = _module((y, v, False), (x_p, u_p, False), options.seed)
        except DomainError:
            continue
        if best is None or gap > best[2]:
            best = (side, module, gap)
        if gap >= SITE_GAP_GOOD:
            break
    if best is None:
        raise DomainError("no_solution", "no module joins the site to its first relay.")
    return best


def build_chain(y_src, v_src, y_tgt, v_tgt, plan: Plan, options: ChainOptions, base=None):
    """The chain of ``plan`` in canonical coordinates: (positions, motion, edges, anchor sets,
    relay node indices), or None when the plan has no port. Nodes: source, target, then each
    module's new nodes in build order."""
    if not plan.source_ports and not plan.target_ports:
        return None
    d = y_src.shape[1]
    asm = _Assembly(np.vstack([y_src, y_tgt]), np.vstack([v_src, v_tgt]))
    k_src = len(y_src)
    sites = ((np.arange(k_src), y_src, v_src), (np.arange(k_src, k_src + len(y_tgt)), y_tgt, v_tgt))
    x_unit, u_unit = port(d, 0.0, 1.0, amplitude=options.amplitude)
    gain_one = options.amplitude is not None
    relays: list[int] = []
    fronts = []
    placed = itertools.count(1)
    if base is not None:
        y_b, v_b, anchors, rest = base
        b_index = asm.add_nodes(y_b, v_b)
        asm.edges.append(np.array([[a, j] for j, subset in zip(b_index, anchors) for a in subset]))
        asm.anchor_sets.extend(tuple(subset) for subset in anchors)
        sites = ((np.r_[b_index, rest], np.vstack([y_b, y_src[rest]]), np.vstack([v_b, v_src[rest]])), sites[1])
    for (index, y, v), ports, mirrored in zip(sites, (plan.source_ports, plan.target_ports), (False, True)):
        if not ports:
            fronts.append((index, y, v, False))
            continue
        side, module, _ = _site_module(y, v, ports, mirrored, options)
        x_p, u_p = side.place(x_unit, u_unit, *ports[0], gain_one)
        p_index = asm.add_nodes(x_p, u_p)
        k = module.given
        asm.add_module(module, np.concatenate([index, p_index]), module.positions[k:], module.motion[k:])
        report_progress(next(placed) / plan.modules, "placed a site's module")
        relays.extend(p_index.tolist())
        base = growth_module(d, options.growth, options.aspect, options.seed, options.amplitude)
        for (t0, a0), (t1, a1) in itertools.pairwise(ports):
            previous = p_index
            x_p, u_p = side.place(x_unit, u_unit, t1, a1, gain_one)
            p_index = asm.add_nodes(x_p, u_p)
            x_new, u_new = side.place(base.positions[base.given :], base.motion[base.given :], t0, a0, gain_one)
            asm.add_module(base, np.concatenate([previous, p_index]), x_new, u_new)
            report_progress(next(placed) / plan.modules, "placed a relay")
            relays.extend(p_index.tolist())
        fronts.append((p_index, x_p, u_p, True))
    (i_a, x_a, u_a, tied_a), (i_b, x_b, u_b, tied_b) = fronts
    module, _ = _module((x_a, u_a, tied_a), (x_b, u_b, tied_b), options.seed)
    asm.add_module(module, np.concatenate([i_a, i_b]), module.positions[module.given :], module.motion[module.given :])
    positions, motion, edges = asm.arrays()
    return positions, motion, edges, tuple(asm.anchor_sets), tuple(relays)


# ----------------------------------------------------------------------------- figures


def response(frame: Frame, source, source_motion: np.ndarray) -> np.ndarray:
    """The motion w (N, d) of every node when the source nodes are driven with ``source_motion``:
    the zero mode with w_S = u_S, from the frame alone — independent of how it was built.

    Q w = 0 with the source rows fixed is Q_F w_F = −Q_S u_S (Q = diag(1/ℓ)·C on the normalised
    frame, F the other rows), solved in least squares: dense QR up to DENSE_MAX_BARS bars,
    else the corrected semi-normal equations (one sparse Cholesky factor of Q_Fᵀ Q_F, then one
    correction from the residual, which brings the error from κ²ε down to κε). Raises
    DomainError ``no_solution`` when the response is not unique (a zero mode moves some node
    while the source stays still)."""
    n, d = frame.n_nodes, frame.dim
    q, _ = _unit_rows(frame.normalised_positions(), frame.edges)
    rows = (np.asarray(source)[:, None] * d + np.arange(d)).ravel()
    free = np.setdiff1d(np.arange(n * d), rows)
    q = q.tocsc()
    q_f = q[:, free]
    b = -(q[:, rows] @ np.ravel(source_motion))
    if q.shape[0] <= DENSE_MAX_BARS:
        dense = q_f.toarray()
        w_f, _, rank, _ = np.linalg.lstsq(dense, b, rcond=None)
        unique = rank == len(free)
    else:
        try:
            factor = cholesky((q_f.T @ q_f).tocsc())
        except ArithmeticError:
            unique = False
        else:
            w_f = factor.solve(q_f.T @ b)
            w_f += factor.solve(q_f.T @ (b - q_f @ w_f))
            unique = True
    if not unique:
        raise DomainError("no_solution", "the response is not unique: a zero mode moves nodes while the source stays still.")
    w = np.zeros(n * d)
    w[rows], w[free] = np.ravel(source_motion), w_f
    return w.reshape(n, d)


def _unit_rows(x: np.ndarray, edges: np.ndarray, u: np.ndarray | None = None):
    """Q = diag(1/ℓ)·C(x) (sparse, N_B × dN): C with unit bar directions; with ``u``, also
    diag(1/ℓ)·C(u), the compatibility matrix built from u in place of the positions."""
    lengths = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)
    scale = sp.diags(1.0 / lengths)
    q = scale @ compatibility_matrix(x, edges)
    return (q, None) if u is None else (q, scale @ compatibility_matrix(u, edges))


def linear_figures(
    frame: Frame, mode: np.ndarray, source, target, site_size: float
) -> tuple[float, float, float, float, float]:
    """(gap, κ_shape, κ_motion, A, A_worst, A_top) of a frame whose zero modes are rigid ⊕ span(mode), no self-stress.

    gap = σ_min(Q)/σ_max(Q) on N(C)^⊥, Q = diag(1/ℓ)·C the unit compatibility matrix (N(Q) =
    N(C); unit rows make it free of the bar-length spread of multi-scale frames): how far the
    softest undesigned motion is from being a zero mode (eigen.smallest_eigenpairs on QᵀQ with
    N(C) deflated).

    Sensitivities. The response to the source motion u_S is w = N N_S⁺ u_S (N an orthonormal
    basis of N(C), N_S its source rows, full column rank). Move the nodes by δx: C is bilinear,
    C(x)u = C(u)x, so the continued zero mode u + δu satisfies C(x) δu = −C(u) δx, solved by
    δu_p = −C⁺ C(u) δx with C⁺ = Qᵀ(QQᵀ)⁻¹ diag(1/ℓ) (no self-stress: QQᵀ is invertible);
    keeping the source rows at u_S (least squares over N) removes N N_S⁺ P_S δu_p, so
        δw_T = J δx,   J = −P_T (I − N N_S⁺ P_S) Qᵀ (QQᵀ)⁻¹ diag(1/ℓ) C(u)
    (the linearisation of tolerance.py's target_response, there as an RMS under uniform pin
    errors). With s = ``site_size`` and Π = I − R_T R_Tᵀ the projector off the rigid motions of
    the target site:
        κ_motion = ‖J‖₂ s / ‖u_T‖: the largest relative change of the target's motion per
            perturbation of Euclidean norm s (all nodes together);
        κ_shape = ‖Π J‖₂ s / ‖Π u_T‖: the same for the target's change of shape (its motion
            modulo rigid motions of the site).
    Any long frame turns an angle error near the source into a displacement of the far end
    proportional to the distance, so κ_motion grows with it; κ_shape — what the target site
    does — need not. Jᵀ comes from one factorisation of QQᵀ and k_tgt·d solves.

    Amplification, the figure a builder feels: node errors in units of the mean bar length ℓ̄
    (what a cutter or printer gets wrong scales with the parts it makes, not with the sites).
    Every node i moves by δx_i = ε ℓ̄ e_i, e_i independent unit vectors uniformly distributed
    in R^d, so E[δx δxᵀ] = (ε ℓ̄)²/d · I and E‖J δx‖² = (ε ℓ̄)² ‖J‖_F²/d; the amplification is
    that relative change of the target's whole motion per relative node error ε, as an RMS:
        A = ‖J‖_F ℓ̄ / (√d ‖u_T‖);
    the worst perturbation with the same RMS node error ε ℓ̄ (‖δx‖ = ε ℓ̄ √N) gives
        A_worst = ‖J‖₂ ℓ̄ √N / ‖u_T‖ ≥ any sampled ‖δw_T‖/(ε ‖u_T‖), to first order in ε.
    and the worst direction's share of A, A_top = ‖J‖₂ ℓ̄/(√d ‖u_T‖) = A_worst/√(dN).
    All are free of translation, rotation and scale (ℓ̄ and J taken on the normalised frame).
    """
    d = frame.dim
    norm = Normalisation.of(frame.positions)
    x = norm.positions_in(frame.positions)
    u = mode / np.max(np.abs(mode))
    q, _ = _unit_rows(x, frame.edges)
    null = _null_space(x, u)
    gram_t = (q.T @ q).tocsc()
    low = smallest_eigenpairs(gram_t, 1, deflate=null).values[0]
    if q.shape[0] > DENSE_MAX_BARS:
        top = float(spla.eigsh(gram_t, k=1, which="LA", return_eigenvectors=False)[0])
    else:
        top = float(np.linalg.norm(q.toarray(), 2) ** 2)
    gap = float(np.sqrt(max(low, 0.0) / top))
    tgt = (np.asarray(target)[:, None] * d + np.arange(d)).ravel()
    jac = response_jacobian(x, frame.edges, u, source, target, null)
    u_t = u.ravel()[tgt]
    rigid_t = rigid_motions(x[np.asarray(target)])
    off_rigid = np.eye(len(tgt)) - rigid_t @ rigid_t.T
    unit = site_size / norm.length
    shape = float(np.linalg.norm(off_rigid @ jac, 2) / np.linalg.norm(off_rigid @ u_t)) * unit
    largest = float(np.linalg.norm(jac, 2))  # ‖J‖₂, one SVD for both figures below
    motion = largest / float(np.linalg.norm(u_t)) * unit
    mean_bar = float(np.mean(bar_lengths(x, frame.edges)))
    amplification = float(np.linalg.norm(jac) * mean_bar / (math.sqrt(d) * np.linalg.norm(u_t)))
    worst = float(largest * mean_bar * math.sqrt(frame.n_nodes) / np.linalg.norm(u_t))
    return gap, shape, motion, amplification, worst, worst / math.sqrt(frame.n_nodes * d)


def _null_space(x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Orthonormal basis of rigid ⊕ span(u) at positions x (any units: the span of the rigid
    motions is free of translation and scale, so it is taken on the normalised positions)."""
    rigid = rigid_motions(Normalisation.of(x).positions_in(x))
    return orthonormal_range(np.column_stack([rigid, u.ravel() / np.max(np.abs(u))]))


def response_jacobian(x: np.ndarray, edges: np.ndarray, u: np.ndarray, source, target, null=None) -> np.ndarray:
    """J = ∂w_T/∂x (k_tgt·d, dN) of the response w driven with the source rows held at u_S, for a
    frame at x (N, d) whose zero modes are rigid ⊕ span(u) with no self-stress (``null``, its
    orthonormal basis, when known): J = −P_T (I − N N_S⁺ P_S) Qᵀ (QQᵀ)⁻¹ diag(1/ℓ) C(u), the
    derivation in ``linear_figures``; one factorisation of QQᵀ (dense up to DENSE_MAX_BARS bars)
    and k_tgt·d solves. In the units of x and u."""
    d = x.shape[1]
    q, cu = _unit_rows(x, edges, u)
    null = _null_space(x, u) if null is None else null
    src = (np.asarray(source)[:, None] * d + np.arange(d)).ravel()
    tgt = (np.asarray(target)[:, None] * d + np.arange(d)).ravel()
    w = np.zeros((x.size, len(tgt)))
    w[tgt, np.arange(len(tgt))] = 1.0
    w[src] -= np.linalg.pinv(null[src]).T @ null[tgt].T
    gram = (q @ q.T).tocsc()
    rhs = q @ w
    if gram.shape[0] <= DENSE_MAX_BARS:
        solved = sla.cho_solve(sla.cho_factor(gram.toarray()), rhs)
    else:
        solved = cholesky(gram).solve(rhs)
    return -(cu.T @ solved).T


# ----------------------------------------------------------------------------- the designer


def check_source_pins(x_src: np.ndarray) -> None:
    """Raise ``underdetermined_source`` unless the source nodes fix every rigid motion (their
    rigid motions have the full dimension d(d+1)/2: 2 distinct points in 2D, 3 non-collinear in
    3D); otherwise a rigid motion that leaves the source still moves the target (a rotation
    about the line of a 3D source pair), and no frame makes the response unique."""
    d = x_src.shape[1]
    if rigid_motions(Normalisation.of(x_src).positions_in(x_src)).shape[1] < d * (d + 1) // 2:
        raise DomainError(
            "underdetermined_source",
            "the source nodes do not fix the rigid motions (in 3D they need 3 non-collinear nodes), "
            "so the target's response to them cannot be unique.",
        )


def _site_checks(x_src, u_src, x_tgt, u_tgt) -> None:
    """Refuse what has no allosteric meaning: sites with coincident nodes (``degenerate_specified``)
    or sharing a point (``overlapping_sites``), a source motion that is zero or rigid
    (``rigid_source``: it would only carry the frame along), a target motion that is zero or
    rigid (``rigid_target``: no conformational response is asked for, and its size is the unit
    of the target error), a source that does not fix the rigid motions (check_source_pins)."""
    for x in (x_src, x_tgt):
        check_specified_distinct(x)
    check_source_pins(x_src)
    both = np.vstack([x_src, x_tgt])
    y = Normalisation.of(both).positions_in(both)
    gaps = np.linalg.norm(y[: len(x_src), None] - y[None, len(x_src) :], axis=2)
    if np.min(gaps) <= DISTINCT_RTOL:
        i, j = np.unravel_index(np.argmin(gaps), gaps.shape)
        raise DomainError(
            "overlapping_sites", f"source node {i} and target node {j} coincide; the sites must be apart."
        )
    for name, code, x, u in (("source", "rigid_source", x_src, u_src), ("target", "rigid_target", x_tgt, u_tgt)):
        try:
            check_motions_nonrigid(x, u[None])
        except DomainError:
            raise DomainError(
                code,
                f"the {name} motion is zero or a rigid motion (translation/rotation) of the {name} "
                f"site; an allosteric design needs a {name} motion that deforms the {name} site.",
            ) from None


def allosteric_inputs(
    source_positions,
    source_motion,
    target_positions,
    target_motion,
    dim: int | None = None,
    seed: int = 0,
    relay_spacing: float | None = None,
    relay_growth: float | None = None,
    robustness: str = "robust",
):
    """design_allosteric's refusals before any chain is built (O(k²) work): the sites
    ((x_src, u_src), (x_tgt, u_tgt)), their canonical similarity and the chain options fixed by
    the request (seed, port, growth).  Raises InvalidInput for shapes and options, DomainError
    for the sites (_site_checks) and ``too_expensive`` when the relays need more than
    MAX_MODULES modules (estimated_modules)."""
    x_src = check_positions(source_positions, dim, "source_positions")
    d = x_src.shape[1]
    u_src = check_positions(source_motion, d, "source_motion")
    x_tgt = check_positions(target_positions, d, "target_positions")
    u_tgt = check_positions(target_motion, d, "target_motion")
    if u_src.shape != x_src.shape or u_tgt.shape != x_tgt.shape:
        raise InvalidInput("invalid_shape", "each site needs one motion row per node.")
    if relay_spacing is not None and not (np.isfinite(relay_spacing) and relay_spacing > 0):
        raise InvalidInput("invalid_options", "relay_spacing must be positive.")
    if relay_growth is not None and not (np.isfinite(relay_growth) and relay_growth >= 1):
        raise InvalidInput("invalid_options", "relay_growth must be at least 1.")
    if robustness not in ROBUSTNESS:
        raise InvalidInput("invalid_options", f"robustness must be one of {', '.join(ROBUSTNESS)}.")
    _site_checks(x_src, u_src, x_tgt, u_tgt)
    sim = canonical(x_src, u_src, x_tgt)
    fixed = {"seed": seed}
    if relay_spacing is not None:
        fixed["port"] = relay_spacing / sim.length
    if relay_growth is not None:
        fixed["growth"] = float(relay_growth)
    first = replace(ChainOptions(), **fixed)
    needed = estimated_modules(float(sim.positions_in(x_tgt)[:, 0].min() - sim.positions_in(x_src)[:, 0].max()), first)
    if needed > MAX_MODULES:
        raise DomainError(
            "too_expensive",
            f"relays of {first.port * sim.length:.3g} growing by {first.growth:g} need about {needed} "
            f"modules across this distance; the limit is {MAX_MODULES} (use larger relays or growth).",
        )
    return (x_src, u_src), (x_tgt, u_tgt), sim, fixed


def design_allosteric(
    source_positions,
    source_motion,
    target_positions,
    target_motion,
    dim: int | None = None,
    seed: int = 0,
    relay_spacing: float | None = None,
    relay_growth: float | None = None,
    robustness: str = "robust",
) -> AllostericDesign:
    """A frame whose only nontrivial zero mode drives the target with u_tgt when the source moves
    with u_src, meeting TARGET_ERROR_MAX and GAP_FLOOR (see the module docstring).

    relay_spacing: size of the first ports next to the sites, in the caller's units (default
    DEFAULT_PORT site sizes); relay_growth: g ≥ 1 (1: equal relays); robustness: "robust"
    designs every chain of ROBUST_CHAINS, rebuilds the best with the source modules of smallest
    ``source_tilt`` among SOURCE_SIDES × REACHES (``_refined``) and returns the acceptable one
    with the smallest amplification A (ResponseFigures), "economy" the first acceptable of
    ALTERNATIVES (fewest nodes; its A grows faster with the distance); either falls back to
    ALTERNATIVES when no robust chain is acceptable. Raises InvalidInput for bad shapes or options; DomainError ``overlapping_sites``, ``degenerate_specified``,
    ``rigid_source``, ``rigid_target``, ``underdetermined_source``, ``too_expensive`` (more than MAX_MODULES modules,
    refused before any work), or InaccurateDesign (``inaccurate_design``, with the best figures).
    """
    (x_src, u_src), (x_tgt, u_tgt), sim, fixed = allosteric_inputs(
        source_positions, source_motion, target_positions, target_motion, dim, seed, relay_spacing, relay_growth,
        robustness,
    )
    first = replace(ChainOptions(), **fixed)
    distance = float(np.linalg.norm(x_tgt.mean(axis=0) - x_src.mean(axis=0)))
    gap = float(sim.positions_in(x_tgt)[:, 0].min() - sim.positions_in(x_src)[:, 0].max())
    robust = []
    if robustness == "robust":
        robust = [c for c in ROBUST_CHAINS if estimated_modules(gap, replace(first, **{**c, **fixed})) <= ROBUST_MAX_MODULES]
    candidates = [(change, True) for change in robust] + [(change, False) for change in ALTERNATIVES]
    best: AllostericDesign | None = None
    accepted: list[AllostericDesign] = []
    failures = []
    tried = set()
    for i, (change, searched) in enumerate(candidates):
        options = replace(first, **{**change, **fixed}) if change else first
        if options in tried or (not searched and accepted):
            continue
        tried.add(options)
        check_budget()
        try:
            with progress_stage(0.8 * i / len(candidates), 0.8 * (i + 1) / len(candidates), f"chain options {i + 1}"):
                result = _attempt(sim, (x_src, u_src), (x_tgt, u_tgt), options, distance)
        except DomainError as exc:
            if exc.code == "too_expensive":
                raise
            failures.append(exc.message)
            continue
        if result.figures.acceptable() and not searched:
            report_progress(1.0, "designed")
            return result
        if result.figures.acceptable():
            accepted.append(result)
        elif best is None or result.figures.rank() < best.figures.rank():
            best = result
    if accepted:
        with progress_stage(0.8, 1.0, "source sides"):
            result = _refined(sim, (x_src, u_src), (x_tgt, u_tgt), accepted, distance)
        report_progress(1.0, "designed")
        return result
    if best is None:
        raise InaccurateDesign(
            f"no chain of modules could be built ({len(failures)} attempts; first: {failures[0]})",
            None,
            None,
            sim.length,
        )
    f = best.figures
    raise InaccurateDesign(
        f"no design met the floors (target error ≤ {TARGET_ERROR_MAX:g}, gap ≥ {GAP_FLOOR:g}) after "
        f"{len(tried)} alternatives; the best has target error {f.target_error:.2e}, gap {f.gap:.2e} "
        f"and sensitivity {f.sensitivity:.2e}.",
        f,
        best.options,
        sim.length,
    )


def _refined(sim: Similarity, src, tgt, accepted: list[AllostericDesign], distance: float) -> AllostericDesign:
    """The acceptable design of smallest amplification among ``accepted`` and the best chain of
    them rebuilt, for each of REACHES, with the REFINED_BUILDS source sides of smallest
    ``source_tilt`` among the source site's first port at each of SOURCE_SIDES (in 2D those
    without twist: a 2D port has none)."""
    accepted = sorted(accepted, key=lambda r: r.figures.amplification_tail())
    best = accepted[0]
    chain = next((r.options for r in accepted if r.modules > 1), None)
    if chain is None:
        return best
    sides = SOURCE_SIDES if len(sim.rotation) == 3 else [s for s in SOURCE_SIDES if s[0] == 0.0]
    screened = []
    reaches = REACHES if len(sim.rotation) == 3 else (0.0,)
    variants = list(itertools.product(reaches, sides))
    for i, (reach, side) in enumerate(variants):
        check_budget()
        report_progress(0.5 * i / len(variants), "screening source modules")
        options = replace(chain, source_side=side, reach=reach)
        _, _, (y_src, v_src, y_tgt, _), plan, direct, base = _canonical_sites(sim, src, tgt, options)
        if direct or not plan.source_ports:
            continue
        try:
            screened.append((source_tilt(y_src, v_src, y_tgt, plan, options, base), i, options))
        except DomainError:
            continue
    chosen = [
        options
        for reach in reaches
        for _, _, options in sorted(s for s in screened if s[2].reach == reach)[:REFINED_BUILDS]
    ]
    for i, options in enumerate(chosen):
        try:
            # Each attempt reports its own 0 → 1; its share keeps the caller's fraction monotone.
            with progress_stage(0.5 + 0.5 * i / len(chosen), 0.5 + 0.5 * (i + 1) / len(chosen), f"source module {i + 1}"):
                result = _attempt(sim, src, tgt, options, distance)
        except DomainError as exc:
            if exc.code == "too_expensive":
                raise
            continue
        if result.figures.acceptable() and result.figures.amplification_tail() < best.figures.amplification_tail():
            best = result
    return best


def _canonical_sites(sim: Similarity, src, tgt, options: ChainOptions):
    """The sites in canonical coordinates for ``options``: (y, v) exact (k, d), the sites (y_src,
    v_src, y_tgt, v_tgt) on the grid (``on_grid``), the plan, whether the sites are joined
    directly, and the source site's base (``source_base``; None without ``options.reach``)."""
    (x_src, u_src), (x_tgt, u_tgt) = src, tgt
    k_src = len(x_src)
    y = sim.positions_in(np.vstack([x_src, x_tgt]))
    v = sim.motions_in(np.vstack([u_src, u_tgt]))
    y_grid, v_grid = on_grid(y), on_grid(v)
    fronts = (float(y_grid[:k_src, 0].max()), float(y_grid[k_src:, 0].min()))
    plan = plan_chain(*fronts, options)
    direct = fronts[1] - fronts[0] < DIRECT_GAP * options.aspect * options.port
    base = None
    if options.reach and not direct:
        base = source_base(y_grid[:k_src], v_grid[:k_src], options.reach * (fronts[1] - fronts[0]))
        plan = plan_chain(max(fronts[0], float(base[0][:, 0].max())), fronts[1], options)
    return y, v, (y_grid[:k_src], v_grid[:k_src], y_grid[k_src:], v_grid[k_src:]), plan, direct, base


def source_base(y: np.ndarray, v: np.ndarray, reach: float):
    """The source site's base: d + 1 nodes far from the site, each joined by d long bars to a
    d-subset of its first d + 1 nodes, so that the chain leaves the site from a base of width
    ~``reach`` instead of the site's own size (ChainOptions.reach).

    A node x_p joined to nodes a of the subset moves with u_p solving (u_a − u_p)·(x_a − x_p) = 0;
    far from the site (|x_p − c| = r ≫ s) the bar directions are nearly parallel, so u_p's part
    across them is ~ r/s times the spread of u_a·n — unless n is normal to the differences
    u_a − u_b of the subset (the null vector of those d − 1 differences), where all u_a·n agree
    and u_p stays of the size of u. Each base node sits at c + r·n (c the site centroid, n
    turned towards the target, e_1·n ≥ 0). A node error then tilts the chain through a base of
    width ~r, not s: measured (3D, the sites that missed the floor) the worst sampled A fell
    4–6× (D = 48: 679 → 164, D = 96: 591 → 92, D = 200: 814 → 140; docs/benchmarks/allostery.md). Each node is one Henneberg step (d bars to d nodes in
    general position): the union keeps its zero modes and has no self-stress.

    Returns base positions and motions (d + 1, d), each node's anchor subset, and the site nodes
    outside the subsets (joined to the chain with the base). Raises DomainError ``no_solution``
    when a base node's bars are degenerate."""
    d = y.shape[1]
    c = y.mean(axis=0)
    positions, motions, anchors = [], [], []
    for subset in itertools.combinations(range(d + 1), d):
        subset = list(subset)
        n = np.linalg.svd(v[subset[1:]] - v[subset[0]])[2][-1]
        x = c + reach * (n if n[0] >= 0 else -n)
        rows = y[subset] - x
        try:
            motions.append(np.linalg.solve(rows, np.einsum("ad,ad->a", v[subset], rows)))
        except np.linalg.LinAlgError:
            raise DomainError("no_solution", "a base node of the source site has degenerate bars.") from None
        positions.append(x)
        anchors.append(subset)
    return np.array(positions), np.array(motions), anchors, np.arange(d + 1, len(y))


def rigid_generators(y: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(dN, d(d+1)/2): the d translations and the infinitesimal rotations about ``centre``
    (2D: e_3 × (y − c); 3D: e_a × (y − c), a = 1, 2, 3) at the points y (N, d), unnormalised."""
    d = y.shape[1]
    r = y - centre
    rotations = [np.column_stack([-r[:, 1], r[:, 0]])] if d == 2 else [np.cross(e, r) for e in np.eye(3)]
    return np.column_stack([np.tile(e, len(y)) for e in np.eye(d)] + [w.ravel() for w in rotations])


def source_tilt(y_src, v_src, y_tgt, plan: Plan, options: ChainOptions, base=None) -> float:
    """How far node errors on the source side move the target through the chain's lever:
    ‖E J_P‖_F, where J_P = ∂(port motion)/∂x is the response Jacobian (``response_jacobian``,
    source rows held at the site's motion) of the source side alone — the source site, its base
    nodes (``source_base``) and the module to the first port P — and E the rigid extension of a
    port motion to the target nodes y_tgt (least-squares rigid fit on P, evaluated at y_tgt).
    The chain carries a rigid motion of its first port rigidly to the target (every relay is a
    zero mode of the union), so for one chain this is A's source-side part up to the factor
    ℓ̄/(√d ‖u_T‖), ~99 % of A in 3D (profile in docs/benchmarks/allostery.md). Canonical
    units; raises DomainError when no module joins the source side to its first port."""
    k = len(y_src)
    site = (np.arange(k), y_src, v_src)
    edges = np.zeros((0, 2), dtype=int)
    if base is not None:
        y_b, v_b, anchors, rest = base
        edges = np.array([[a, k + j] for j, subset in enumerate(anchors) for a in subset])
        site = (np.r_[np.arange(k, k + len(y_b)), rest], np.vstack([y_b, y_src[rest]]), np.vstack([v_b, v_src[rest]]))
    side, module, _ = _site_module(site[1], site[2], plan.source_ports, False, options)
    x_unit, u_unit = port(y_src.shape[1], 0.0, 1.0, amplitude=options.amplitude)
    x_p, u_p = side.place(x_unit, u_unit, *plan.source_ports[0], options.amplitude is not None)
    first = k + (0 if base is None else len(base[0]))
    port_nodes = np.arange(first, first + len(x_p))
    index = np.r_[site[0], port_nodes, np.arange(first + len(x_p), first + len(x_p) + module.unspecified)]
    x = np.vstack([y_src] + ([base[0]] if base is not None else []) + [x_p, module.positions[module.given :]])
    u = np.vstack([v_src] + ([base[1]] if base is not None else []) + [u_p, module.motion[module.given :]])
    edges = np.vstack([edges, index[module.edges]])
    jac = response_jacobian(x, edges, u, np.arange(k), port_nodes)
    c = x_p.mean(axis=0)
    extension = rigid_generators(y_tgt, c) @ np.linalg.pinv(rigid_generators(x_p, c))
    return float(np.linalg.norm(extension @ jac))


def _attempt(sim: Similarity, src, tgt, options: ChainOptions, distance: float) -> AllostericDesign:
    """One design with these chain options, verified and measured.

    src, tgt: (x, u) of each site in the caller's units. The chain is built from the sites'
    canonical coordinates rounded to a grid (``on_grid``), so a similar request builds the
    very same canonical chain — a solution space sampled in a basis that a rounding error can
    rotate would otherwise pick other points — and the unspecified nodes joined to a site are
    then moved onto the exact sites' solution spaces (``_polish``, a ~1e-12 correction)."""
    (x_src, u_src), (x_tgt, u_tgt) = src, tgt
    k_src, k = len(x_src), len(x_src) + len(x_tgt)
    y, v, sites, plan, direct, base = _canonical_sites(sim, src, tgt, options)
    y_grid, v_grid = np.vstack(sites[::2]), np.vstack(sites[1::2])
    with progress_stage(0.0, 0.8, "one module" if direct else "chain"):
        chain = None if direct else build_chain(*sites, plan, options, base)
        joined = design(y_grid, v_grid, seed=options.seed) if chain is None else None
    if joined is not None:
        positions, motion = joined.frame.positions.copy(), joined.modes[0].copy()
        edges, anchor_sets, relays, modules = joined.frame.edges, joined.anchor_sets, (), 1
    else:
        positions, motion, edges, anchor_sets, relays = chain
        modules = plan.modules
    positions[:k], motion[:k] = y, v
    _polish(positions, motion, edges, k)
    if base is not None:  # the base's own neighbours next: the base moved by its r/s × the grid
        _polish(positions, motion, edges, k + len(base[0]))
    x = np.vstack([x_src, x_tgt, sim.positions_out(positions[k:])])
    u = np.vstack([u_src, u_tgt, sim.motions_out(motion[k:])])
    frame = Frame.build(x, edges, specified=range(k))
    result = verify(frame, u[None], anchor_sets)
    report_progress(0.9, "verified the frame")
    source, target = np.arange(k_src), np.arange(k_src, k)
    achieved = response(frame, source, u_src)[target]
    error = float(np.linalg.norm(achieved - u_tgt) / np.linalg.norm(u_tgt))
    gap, shape, motion_k, amplification, worst, top = linear_figures(frame, u, source, target, sim.length)
    figures = ResponseFigures(
        achieved, error, gap, shape * SENSITIVITY_PERTURBATION, motion_k * SENSITIVITY_PERTURBATION, amplification, worst, top
    )
    return AllostericDesign(
        design=result,
        source=tuple(source.tolist()),
        target=tuple(target.tolist()),
        relays=tuple(relays),
        figures=figures,
        distance=distance,
        modules=modules,
        options=options,
        site_size=sim.length,
    )


# Canonical site coordinates are rounded to 2^-GRID_BITS of their largest magnitude: far below
# any geometric decision (placement quantises its keys to 1e-6), far above the ~1e-16 by which
# similar requests differ after their canonical map.
GRID_BITS = 40
# Gauss–Newton steps of ``_polish``; it starts ~1e-12 away and converges quadratically.
POLISH_STEPS = 6


def on_grid(a: np.ndarray, bits: int = GRID_BITS) -> np.ndarray:
    """``a`` rounded to multiples of 2^(⌊log₂ max|a|⌋ − bits): a canonical value that similar
    requests, differing by round-off far below the grid, share."""
    peak = float(np.max(np.abs(a)))
    grid = 2.0 ** (math.floor(math.log2(peak)) - bits) if peak > 0 else 1.0
    return np.round(a / grid) * grid


def _polish(positions: np.ndarray, motion: np.ndarray, edges: np.ndarray, k: int) -> None:
    """Move each unspecified node joined to one of the first k nodes (the sites, now exact) onto
    the nearest point (x_U, u_U) of its solution space: Gauss–Newton with least-norm steps on
    its bars' constraints (x_a − x_U)·(u_a − u_U) = 0 (at most 2d of them in 2d unknowns: an
    anchor set of 2d + 1 nodes has no real point in general). In place; canonical units."""
    touched = np.unique(edges[(edges < k).any(axis=1)].max(axis=1))
    for j in touched[touched >= k]:
        anchors = np.concatenate([edges[edges[:, 1] == j, 0], edges[edges[:, 0] == j, 1]])
        for _ in range(POLISH_STEPS):
            dx, du = positions[anchors] - positions[j], motion[anchors] - motion[j]
            residual = np.einsum("ad,ad->a", dx, du)
            step = np.linalg.lstsq(np.hstack([-du, -dx]), -residual, rcond=None)[0]
            d = positions.shape[1]
            positions[j] += step[:d]
            motion[j] += step[d:]
