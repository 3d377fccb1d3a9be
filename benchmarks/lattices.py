"""Lattice frames for benchmarks and tests: periodic bar-and-joint lattices cut to a patch.

A lattice is a Bravais lattice (vectors ``a_1..a_d``, rows of ``lattice``) with a basis of
sites (rows of ``basis``, in lattice coordinates) and a list of bonds ``(s, t, offset)``
joining site ``s`` of cell ``c`` to site ``t`` of cell ``c + offset``. The patch keeps the
cells ``0 ≤ c_k < m`` (a parallelogram / parallelepiped of m^d cells) and every bond whose
two cells lie in it, so the boundary carries the floppy modes of the cut.

Every generator takes a target node count ``n`` (the patch side is chosen so the count is
close to it; ``Frame.n_nodes`` is the exact count), an optional ``jitter`` (node
displacements drawn uniformly from a ball of that radius, in bond lengths, to make the
configuration generic) and a ``seed`` for the jitter.

Counts of the perfect lattices (N nodes, m cells per side):
  * triangulated (2D, z = 6): rigid, self-stresses (m − 2)²;
  * kagome (2D, z = 4 in the bulk, Maxwell-marginal): O(m) zero modes along the boundary,
    no self-stress (its straight lines of bonds end on the free boundary);
  * square (2D, z = 4): without jitter no self-stress (the bars of a row constrain only
    that row's x-differences) and 2m zero modes (every row slides along x, every column along y);
  * cubic with face diagonals (3D, z = 12): rigid, about 3N self-stresses;
  * face-centred cubic (3D, z = 12): rigid, about 3N self-stresses.
"""

from __future__ import annotations

import numpy as np

from zeromode.solver import Frame

_SQRT3 = np.sqrt(3.0)


def _patch(
    n: int,
    lattice: np.ndarray,
    basis: np.ndarray,
    bonds: list[tuple[int, int, tuple[int, ...]]],
    jitter: float,
    seed: int,
) -> Frame:
    """Cut m^d cells of the lattice, m chosen so that m^d · (sites per cell) ≈ n."""
    d = lattice.shape[0]
    b = len(basis)
    m = max(1, round((n / b) ** (1.0 / d)))
    cells = np.stack(np.meshgrid(*[np.arange(m)] * d, indexing="ij"), axis=-1).reshape(-1, d)
    cell_id = np.arange(len(cells)).reshape((m,) * d)
    positions = ((cells[:, None, :] + basis[None, :, :]) @ lattice).reshape(-1, d)
    edges = []
    for s, t, offset in bonds:
        target = cells + np.asarray(offset)
        inside = np.all((target >= 0) & (target < m), axis=1)
        here = np.flatnonzero(inside)
        there = cell_id[tuple(target[inside].T)]
        edges.append(np.column_stack([b * here + s, b * there + t]))
    if jitter > 0:
        rng = np.random.default_rng(seed)
        direction = rng.standard_normal(positions.shape)
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        radius = jitter * rng.random((len(positions), 1)) ** (1.0 / d)
        positions = positions + radius * direction
    return Frame.build(positions, np.concatenate(edges), dim=d)


def triangulated_lattice(n: int, jitter: float = 0.0, seed: int = 0) -> Frame:
    """2D triangular lattice (unit bonds, coordination 6) on an m × m rhombic patch, N = m²."""
    lattice = np.array([[1.0, 0.0], [0.5, _SQRT3 / 2]])
    bonds = [(0, 0, (1, 0)), (0, 0, (0, 1)), (0, 0, (-1, 1))]
    return _patch(n, lattice, np.zeros((1, 2)), bonds, jitter, seed)


def square_lattice(n: int, jitter: float = 0.0, seed: int = 0) -> Frame:
    """2D square lattice (unit bonds, coordination 4), N = m²: a hard case for rank decisions.

    Without jitter every row slides freely along x and every column along y: 2m zero modes
    (3 of them rigid), no self-stress, and many singular values at the threshold's scale once
    jittered.
    """
    bonds = [(0, 0, (1, 0)), (0, 0, (0, 1))]
    return _patch(n, np.eye(2), np.zeros((1, 2)), bonds, jitter, seed)


def kagome_lattice(n: int, jitter: float = 0.0, seed: int = 0) -> Frame:
    """2D kagome lattice (corner-sharing unit triangles, coordination 4), N = 3m².

    Sites 0, 1, 2 at 0, a_1/2, a_2/2 form the "up" triangle of a cell; the "down" triangle
    joins site 1 of cell c to site 0 of c + (1, 0) and to site 2 of c + (1, −1).
    """
    lattice = np.array([[2.0, 0.0], [1.0, _SQRT3]])
    basis = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5]])
    bonds = [
        (0, 1, (0, 0)),
        (0, 2, (0, 0)),
        (1, 2, (0, 0)),
        (1, 0, (1, 0)),
        (2, 0, (0, 1)),
        (1, 2, (1, -1)),
    ]
    return _patch(n, lattice, basis, bonds, jitter, seed)


def cubic_diagonal_lattice(n: int, jitter: float = 0.0, seed: int = 0) -> Frame:
    """3D simple cubic lattice with one diagonal on every square face (coordination 12), N = m³.

    Every cube then has six triangulated faces, hence is rigid (Cauchy–Dehn), and so is the patch.
    """
    bonds = [
        (0, 0, (1, 0, 0)),
        (0, 0, (0, 1, 0)),
        (0, 0, (0, 0, 1)),
        (0, 0, (1, 1, 0)),
        (0, 0, (0, 1, 1)),
        (0, 0, (1, 0, 1)),
    ]
    return _patch(n, np.eye(3), np.zeros((1, 3)), bonds, jitter, seed)


def fcc_lattice(n: int, jitter: float = 0.0, seed: int = 0) -> Frame:
    """3D face-centred cubic lattice, nearest-neighbour bonds (coordination 12), N = 4m³.

    Conventional cubic cell with its four sites; bonds join sites at distance 1/√2.
    """
    basis = np.array([[0, 0, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [0.5, 0.5, 0]])
    bonds = []
    for s in range(4):
        for t in range(4):
            for offset in np.ndindex(3, 3, 3):
                o = np.array(offset) - 1
                key = (tuple(o), t) > ((0, 0, 0), s)  # each bond once
                if key and np.isclose(np.linalg.norm(basis[t] + o - basis[s]), np.sqrt(0.5)):
                    bonds.append((s, t, tuple(int(k) for k in o)))
    return _patch(n, np.eye(3), basis, bonds, jitter, seed)


LATTICES = {
    "triangulated": triangulated_lattice,
    "kagome": kagome_lattice,
    "square": square_lattice,
    "cubic-diagonal": cubic_diagonal_lattice,
    "fcc": fcc_lattice,
}
