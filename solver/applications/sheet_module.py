"""Mirror-symmetric modules of 2D auxetic sheets and their exact finite motion (paper,
Supplementary "Combining Networks with Repeating Modules", Fig. S1).

A module has four corners (±a, ±b) and unspecified nodes in orbits of its two mirror symmetries
x ↦ −x and y ↦ −y: pairs on the x-axis (±c, 0), pairs on the y-axis (0, ±e), or quadruples
(±x, ±y).  A symmetric configuration is a point q = (a, b, orbit coordinates) ∈ R^{n_q}, and the
positions are linear in it: X = B·q, with B (N × 2 × n_q) holding the mirror signs.  Bars come
in orbits too; the bars of one orbit have equal lengths in every symmetric configuration, so
one equation per orbit k (representative bar (i, j)),

    g_k(q) = |X_i(q) − X_j(q)|² − ℓ_k² = 0,

describes the symmetric configurations.  The modules here have n_q − 1 bar orbits: their
symmetric configurations form a curve, which the axial strain ε = a/w − 1 parametrises wherever
the square Jacobian J_U = ∂g/∂(b, orbit coordinates) is regular (implicit function theorem).
Each configuration is then the Newton solution of g(q) = 0 at its strain, exact to round-off.

Why tiling works (the supplement's argument, made exact): a symmetric configuration has its
corners at (±a, ±b), an affine image of the reference corners, so copies on a 2a × 2b grid
sharing corners fit at every strain, and the sheet follows the module's curve with every bar at
its length.  That this is the sheet's only motion is checked by a rank analysis of the tiled
sheet (lattice.py).

Families (by the number n_U of unspecified nodes):
  2 — the paper's Fig. S1a: an x-axis pair joined to all four corners (bar orbits: near and far
      corners).  Its coordinate c is fixed by the linear Poisson ratio, c² = w² + βh², which
      leaves no freedom for the finite motion.
  4 — a trammel: an x-axis pair (±c, 0) and a y-axis pair (0, ±e), each node joined to its two
      nearest corners, and every x-axis node to every y-axis node.  By symmetry the pairs slide
      on the axes, so the rod (c, 0)–(0, e) is the trammel of Archimedes and the corner, rigidly
      joined to both of its ends, traces the ellipse P(φ) = M·(cos φ, sin φ) with the symmetric
      M = [[ℓ − u, v], [v, u]] (ℓ = |rod|, (u, v) the corner in the rod's frame).  Every ellipse
      centred on the module's centre is the image of the unit circle under a symmetric matrix,
      so (c, e) choose the ellipse: one combination fixes the linear Poisson ratio, the other its
      curvature along the affine path — the freedom finite_strain.py uses to hold the secant
      Poisson ratio over a strain range.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from zeromode.solver.errors import DomainError
from zeromode.solver.tolerances import MODULE_NEWTON_RTOL, TRAMMEL_DEGENERATE_RTOL

# The mirror images of a point, as sign patterns; the corners are node 0..3 in this order (the
# order lattice.py has always used: (w, h), (−w, h), (−w, −h), (w, −h)).
MIRRORS = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], dtype=float)
# Coordinates of each orbit kind, and which mirror signs tell its nodes apart.
_KIND_COORDS = {"corner": 2, "x": 1, "y": 1, "generic": 2}
# Newton iterations on g(q) = 0 (to MODULE_NEWTON_RTOL).
NEWTON_MAX_ITER = 30
# A Newton step larger than this fraction of the module's size has left the configuration's
# neighbourhood (another branch, or no configuration at this strain).
MAX_NEWTON_STEP = 0.25


@dataclass(frozen=True, eq=False)
class SymmetricModule:
    """A mirror-symmetric module.

    name: its family; kinds: the orbit kinds, "corner" first; basis B (N, 2, n_q): X = B·q;
    orbit (N,): the orbit of each node; bar_orbits (n_o, 2): a representative bar per orbit;
    edges (N_B, 2): every bar; reference q₀ (n_q,) = (w, h, orbit coordinates) at ε = 0;
    squared_lengths (n_o,): ℓ_k² at q₀.
    """

    name: str
    kinds: tuple[str, ...]
    basis: np.ndarray
    orbit: np.ndarray
    bar_orbits: np.ndarray
    edges: np.ndarray
    reference: np.ndarray
    squared_lengths: np.ndarray

    @classmethod
    def build(cls, name: str, kinds, coords, bar_orbits) -> SymmetricModule:
        """kinds: orbit kinds after the corners; coords: q₀ (w, h, then each orbit's coordinates);
        bar_orbits: representative bars as pairs of (orbit, image) with image an index into
        MIRRORS (an axis orbit's image is read from the sign that tells its nodes apart)."""
        kinds = ("corner", *kinds)
        columns, rows, orbit_of, keys = 0, [], [], {}
        for o, kind in enumerate(kinds):
            seen = []
            for g, sign in enumerate(MIRRORS):
                key = _image_key(kind, sign)
                if key in seen:
                    continue
                seen.append(key)
                keys[(o, key)] = len(rows)
                b = np.zeros((2, len(coords)))
                if kind in ("corner", "generic"):
                    b[0, columns], b[1, columns + 1] = sign
                elif kind == "x":
                    b[0, columns] = sign[0]
                else:
                    b[1, columns] = sign[1]
                rows.append(b)
                orbit_of.append(o)
            columns += _KIND_COORDS[kind]
        if columns != len(coords):
            raise ValueError(f"{name}: {len(coords)} coordinates for orbits needing {columns}.")
        def node(o: int, g: int) -> int:
            """The node of orbit o that is the image of its representative under mirror g."""
            return keys[(o, _image_key(kinds[o], MIRRORS[g]))]

        reps = np.array([[node(*a), node(*b)] for a, b in bar_orbits], dtype=int)
        edges = []
        for (oa, ga), (ob, gb) in bar_orbits:
            for sign in MIRRORS:
                ends = (node(oa, _mirror_index(MIRRORS[ga] * sign)), node(ob, _mirror_index(MIRRORS[gb] * sign)))
                e = tuple(sorted(ends))
                if e not in edges:
                    edges.append(e)
        # Sorted by (higher, lower) node: the two-node module's bars in lattice.py's historic order.
        edges.sort(key=lambda e: (e[1], e[0]))
        basis = np.stack(rows)
        q0 = np.asarray(coords, dtype=float)
        x0 = basis @ q0
        d = x0[reps[:, 0]] - x0[reps[:, 1]]
        return cls(name, kinds, basis, np.asarray(orbit_of), reps, np.array(edges, dtype=int), q0, np.sum(d * d, axis=1))

    def with_reference(self, q: np.ndarray) -> SymmetricModule:
        """The module of the same topology whose reference is q (n_q,) (its bar lengths ℓ_k at q)."""
        q = np.asarray(q, dtype=float)
        x = self.basis @ q
        d = x[self.bar_orbits[:, 0]] - x[self.bar_orbits[:, 1]]
        return dataclasses.replace(self, reference=q, squared_lengths=np.sum(d * d, axis=1))

    @property
    def n_nodes(self) -> int:
        return int(self.basis.shape[0])

    @property
    def n_unspecified(self) -> int:
        return self.n_nodes - 4

    @property
    def cell(self) -> tuple[float, float]:
        """(w, h): the reference half-width and half-height."""
        return float(self.reference[0]), float(self.reference[1])

    def positions(self, q: np.ndarray) -> np.ndarray:
        """X = B·q: (N, 2) for q (n_q,), or (..., N, 2) for q (..., n_q)."""
        return np.einsum("nij,...j->...ni", self.basis, q)

    def residual(self, q: np.ndarray) -> np.ndarray:
        """g(q) / ℓ² (n_o,): relative squared-length errors of the bar orbits."""
        x = self.positions(q)
        d = x[self.bar_orbits[:, 0]] - x[self.bar_orbits[:, 1]]
        return np.sum(d * d, axis=1) / self.squared_lengths - 1.0

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """∂(g/ℓ²)/∂q (n_o, n_q)."""
        x = self.positions(q)
        i, j = self.bar_orbits[:, 0], self.bar_orbits[:, 1]
        return 2 * np.einsum("ki,kij->kj", x[i] - x[j], self.basis[i] - self.basis[j]) / self.squared_lengths[:, None]

    def configuration(self, strain: float, start: np.ndarray) -> np.ndarray | None:
        """The symmetric configuration q at ε = ``strain`` (a = w(1 + ε)) by Newton from
        ``start``; None when Newton leaves the neighbourhood or J_U is singular there."""
        q = np.array(start, dtype=float)
        q[0] = self.reference[0] * (1.0 + strain)
        size = float(np.max(np.abs(self.reference)))
        previous = np.inf
        for _ in range(NEWTON_MAX_ITER):
            r = self.residual(q)
            error = float(np.max(np.abs(r)))
            if error <= MODULE_NEWTON_RTOL:
                return q
            if error >= previous:  # Newton contracts near a regular solution; this one does not
                return None
            previous = error
            try:
                step = np.linalg.solve(self.jacobian(q)[:, 1:], -r)
            except np.linalg.LinAlgError:
                return None
            if not np.all(np.isfinite(step)) or np.max(np.abs(step)) > MAX_NEWTON_STEP * size:
                return None
            q[1:] += step
        return None

    def tangent(self, q: np.ndarray) -> np.ndarray:
        """dq/dε (n_q,) along the symmetric curve: dq₀/dε = w and J_U·dq_U/dε = −w·∂g/∂a."""
        jac = self.jacobian(q)
        w = self.reference[0]
        rest = np.linalg.solve(jac[:, 1:], -w * jac[:, 0])
        return np.concatenate([[w], rest])


def _image_key(kind: str, sign: np.ndarray) -> tuple:
    """What tells the nodes of an orbit apart: both signs, or one for an axis pair."""
    if kind == "x":
        return (sign[0],)
    if kind == "y":
        return (sign[1],)
    return (sign[0], sign[1])


def _mirror_index(sign: np.ndarray) -> int:
    return int(np.flatnonzero(np.all(MIRRORS == sign, axis=1))[0])


def two_node_module(w: float, h: float, c: float) -> SymmetricModule:
    """Fig. S1a: corners (±w, ±h), nodes (±c, 0) each joined to the four corners."""
    return SymmetricModule.build("two_node", ("x",), (w, h, c), [((1, 0), (0, 0)), ((1, 0), (0, 1))])


def trammel_module(w: float, h: float, c: float, e: float) -> SymmetricModule:
    """Corners (±w, ±h), x-axis nodes (±c, 0) and y-axis nodes (0, ±e); (c, 0) joined to (w, ±h),
    (0, e) to (±w, h), and every x-axis node to every y-axis node."""
    return SymmetricModule.build(
        "trammel", ("x", "y"), (w, h, c, e), [((1, 0), (0, 0)), ((2, 0), (0, 0)), ((1, 0), (2, 0))]
    )


def cardan_trammel(w: float, h: float, c: float) -> SymmetricModule:
    """The trammel whose corner lies on the circle with diameter the rod (c, 0)–(0, e):
    (w − c)·w + (h − e)·h = 0, e = h + w(w − c)/h.  That circle rolls inside the circle of radius
    ℓ about the centre (Cardan's circles), so the corner moves on a straight line through the
    centre: a = w·t, b = h·t along the whole motion — secant Poisson ratio −1 exactly (the
    ellipse of trammel_coordinates degenerates to this segment at β = 1)."""
    return trammel_module(w, h, c, h + w * (w - c) / h)


def trammel_coordinates(w: float, h: float, beta: float, stretch: float, sign: float) -> tuple[float, float]:
    """(c, e) of the trammel whose corner traces the ellipse with conjugate semi-diameters
    p = (w, h) and q = stretch·(w, βh): through the reference corner, tangent there to the affine
    path (w(1 + ε), h(1 + βε)) of linear Poisson ratio −β.  Along the ellipse the secant ratio
    departs from −β by O(ε/stretch²) (finite_strain.py).

    With P = [p q], the symmetric M with M·Mᵀ = P·Pᵀ is V·diag(s₁√μ₁, s₂√μ₂)·Vᵀ (P·Pᵀ = V·diag(μ)·Vᵀ;
    ``sign`` = s₂ with s₁ = +1, the two trammels that are not mirror images); the rod has length
    ℓ = tr M, the reference angle is (cos φ₀, sin φ₀) = M⁻¹·p, and c = ℓ cos φ₀, e = ℓ sin φ₀.
    """
    p = np.array([w, h])
    pq = np.column_stack([p, stretch * np.array([w, beta * h])])
    mu, v = np.linalg.eigh(pq @ pq.T)
    m = v @ np.diag(np.sqrt(np.maximum(mu, 0.0)) * np.array([sign, 1.0])) @ v.T
    if abs(np.linalg.det(m)) <= TRAMMEL_DEGENERATE_RTOL * float(np.sum(mu)):
        raise DomainError("no_solution", "the trammel for this Poisson ratio is degenerate.")
    rod = float(np.trace(m))
    cos_sin = np.linalg.solve(m, p)
    return rod * float(cos_sin[0]), rod * float(cos_sin[1])


# ----------------------------------------------------------------------------------------------
# Tiling: an n_x × n_y sheet of copies sharing corners


def sheet_positions(module: SymmetricModule, nx: int, ny: int, q: np.ndarray) -> np.ndarray:
    """Sheet positions at the module configuration q: the corner grid ((n_x+1)(n_y+1) nodes,
    row-major in y then x, spacing 2a × 2b, centred) followed by each module's unspecified
    nodes (modules row-major in y then x, n_U nodes each, at the module's centre + X_U(q))."""
    a, b = q[0], q[1]
    px, py = np.meshgrid((2 * np.arange(nx + 1) - nx) * a, (2 * np.arange(ny + 1) - ny) * b)
    corners = np.column_stack([px.ravel(), py.ravel()])
    cx, cy = np.meshgrid((2 * np.arange(nx) + 1 - nx) * a, (2 * np.arange(ny) + 1 - ny) * b)
    centres = np.column_stack([cx.ravel(), cy.ravel()])
    inner = module.positions(q)[4:]
    return np.vstack([corners, (centres[:, None, :] + inner[None]).reshape(-1, 2)])


def sheet_velocities(module: SymmetricModule, nx: int, ny: int, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """d(sheet positions)/dε for dq = dq/dε: the sheet's motion along the module's curve (the
    positions are linear in (a, b, X_U), so it is sheet_positions' formula applied to dq with
    the centres moving by their own grid)."""
    grid = sheet_positions(module, nx, ny, np.concatenate([dq[:2], np.zeros(len(dq) - 2)]))
    n_corners = (nx + 1) * (ny + 1)
    grid[n_corners:] += np.tile(module.positions(dq)[4:], (nx * ny, 1))
    return grid


def sheet_edges(module: SymmetricModule, nx: int, ny: int) -> np.ndarray:
    """Every module bar for every module, grouped by module bar: corner k of module (i, j) is grid
    corner (i + (1, 0, 0, 1)_k, j + (1, 1, 0, 0)_k), unspecified node t is n_corners + n_U·m + t."""
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    i, j = i.ravel(), j.ravel()
    di, dj = np.array([1, 0, 0, 1]), np.array([1, 1, 0, 0])
    n_u = module.n_unspecified
    first = (nx + 1) * (ny + 1) + n_u * np.arange(nx * ny)

    def sheet_node(k: int) -> np.ndarray:
        if k < 4:
            return (j + dj[k]) * (nx + 1) + i + di[k]
        return first + (k - 4)

    return np.vstack([np.column_stack([sheet_node(a), sheet_node(b)]) for a, b in module.edges])
