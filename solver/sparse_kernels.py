"""Compiled inner steps of the sparse rank route (solver/rigidity.py), on CSR arrays.

A sparse matrix A (m × n) is passed as its CSR arrays: ``indptr`` (m + 1), ``indices`` and
``data`` (one entry each, column and value), int64 indices. Blocks of vectors are (n, k) arrays.
Each function is one step of the route, compiled by numba (cached on disk after the first call
in an environment):

  * ``compatibility_csr``: C (N_B × dN) from the bars, row e = (x_i − x_j) at node i, its
    negative at node j (paper, Eq. 3);
  * ``rigid_motion_svd``: the SVD of the rigid motions' generators (the known null vectors);
  * ``uniform_block``: the starting blocks' pseudo-random numbers (SplitMix64);
  * ``transpose_csr``: Aᵀ; ``row_gram``: A Aᵀ (CᵀC from A = Cᵀ, CCᵀ from A = C);
  * ``times``: A·Y;
  * ``largest_singular_value``: σ_max(A) by Lanczos on AᵀA; ``product_norm``: ‖A·Y‖₂;
  * ``ritz_pairs``: Rayleigh–Ritz singular values and vectors of A on span(Y);
  * ``project_out_and_orthonormalise``: Q of (I − K Kᵀ) Y.

Hot loops index through np.uint64 casts (``_u``): numba checks every signed index for
wraparound, which made a product with C 1.7× slower than SciPy's at 10⁴ nodes (69 against 40 µs);
with the casts the two are level.

Why compiled: at 10² nodes every step handles a few hundred numbers, and the count made some
forty NumPy and SciPy calls whose per-call overhead (1–60 µs each, more inside a count than
alone: the cache is cold) cost more than the CHOLMOD factorisation itself (0.2–0.7 ms); at 10⁴
nodes and more the same loops run as fast as SciPy's. ``warm_up`` compiles them all ahead of
the first request.
"""

from __future__ import annotations

from itertools import product

import numpy as np

from zeromode.solver.compiled import compiled
from zeromode.solver.normalisation import normalised

_u = np.uint64


@compiled
def compatibility_csr(positions, edges):
    """CSR arrays of C (N_B × dN) for positions (N, d) and edges (N_B, 2) int64.

    Row e lists the lower-numbered node of its bar first: its d columns hold x_first − x_second,
    the other node's the negative (sorted columns, 2d entries a row)."""
    d = positions.shape[1]
    nb = edges.shape[0]
    indptr = np.arange(0, 2 * d * nb + 1, 2 * d).astype(np.int64)
    indices = np.empty(2 * d * nb, np.int64)
    data = np.empty(2 * d * nb)
    for e in range(nb):
        first, second = min(edges[e, 0], edges[e, 1]), max(edges[e, 0], edges[e, 1])
        base = 2 * d * e
        for a in range(d):
            v = positions[first, a] - positions[second, a]
            indices[base + a] = d * first + a
            data[base + a] = v
            indices[base + d + a] = d * second + a
            data[base + d + a] = -v
    return indptr, indices, data


@compiled
def rigid_motion_svd(positions):
    """Thin SVD (U, s) of the dN × d(d+1)/2 matrix whose columns generate the rigid motions at
    ``positions`` (N ≥ 1, d): the d translations and the rotations u_i = E_ab x_i (E_ab the
    elementary skew matrices), node-major (u_i in rows d·i … d·i + d − 1)."""
    n, d = positions.shape
    generators = np.zeros((n * d, d * (d + 1) // 2))
    for a in range(d):
        for i in range(n):
            generators[i * d + a, a] = 1.0
    k = d
    for a in range(d):
        for b in range(a + 1, d):
            for i in range(n):
                generators[i * d + a, k] = -positions[i, b]
                generators[i * d + b, k] = positions[i, a]
            k += 1
    u, s, _ = np.linalg.svd(generators, full_matrices=False)
    return u, s


@compiled
def uniform_block(state, rows, cols):
    """A (rows, cols) block of numbers uniform in [−1, 1): the next rows·cols outputs of the
    SplitMix64 sequence (Steele, Lea & Flood 2014) whose state, ``state[0]`` (uint64), is
    advanced in place; each output's top 53 bits b give b·2⁻⁵² − 1."""
    out = np.empty((rows, cols))
    s = state[0]
    for i in range(rows):
        for j in range(cols):
            s += np.uint64(0x9E3779B97F4A7C15)
            z = (s ^ (s >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
            z ^= z >> np.uint64(31)
            out[i, j] = float(z >> np.uint64(11)) * 2.0**-52 - 1.0
    state[0] = s
    return out


@compiled
def transpose_csr(indptr, indices, data, ncols):
    """CSR arrays of Aᵀ (ncols × m) from those of A (m × ncols); columns ascending in each row."""
    m = indptr.size - 1
    t_indptr = np.zeros(ncols + 1, np.int64)
    for p in range(indptr[m]):
        t_indptr[indices[p] + 1] += 1
    for j in range(ncols):
        t_indptr[j + 1] += t_indptr[j]
    fill = t_indptr[:ncols].copy()
    t_indices = np.empty(indptr[m], np.int64)
    t_data = np.empty(indptr[m])
    for r in range(m):
        for p in range(indptr[r], indptr[r + 1]):
            q = fill[indices[p]]
            t_indices[q] = r
            t_data[q] = data[p]
            fill[indices[p]] += 1
    return t_indptr, t_indices, t_data


@compiled
def row_gram(indptr, indices, data, t_indptr, t_indices, t_data):
    """CSR arrays of A Aᵀ (m × m) from A (m × n) and Aᵀ, both CSR: entry (i, j) = Σ_k a_ik a_jk.

    Gustavson's row-by-row product in one pass into room for every product term, then compacted;
    a row's columns come in the order they are first met (the same every time). Entries that sum
    to exactly zero are left out, as SciPy's product does: the blocks u uᵀ of axis-aligned bars
    are mostly zeros, which CHOLMOD would otherwise take as structural nonzeros (more fill)."""
    m = indptr.size - 1
    room = 0
    for p in range(indptr[m]):
        k = indices[p]
        room += t_indptr[k + 1] - t_indptr[k]
    out_indptr = np.zeros(m + 1, np.int64)
    out_indices = np.empty(room, np.int64)
    out_data = np.empty(room)
    owner = np.full(m, -1, np.int64)  # the row whose entry j was last started
    slot = np.empty(m, np.int64)
    kept = 0
    for i in range(m):
        row_start = kept
        for p in range(_u(indptr[i]), _u(indptr[i + 1])):
            k, v = _u(indices[p]), data[p]
            for q in range(_u(t_indptr[k]), _u(t_indptr[k + 1])):
                j = _u(t_indices[q])
                if owner[j] != i:
                    owner[j] = i
                    slot[j] = kept
                    out_indices[kept] = j
                    out_data[kept] = v * t_data[q]
                    kept += 1
                else:
                    out_data[slot[j]] += v * t_data[q]
        end = row_start
        for p in range(row_start, kept):
            if out_data[p] != 0.0:
                out_indices[end] = out_indices[p]
                out_data[end] = out_data[p]
                end += 1
        kept = end
        out_indptr[i + 1] = kept
    return out_indptr, out_indices[:kept].copy(), out_data[:kept].copy()


@compiled
def times(indptr, indices, data, y):
    """A·Y (m × k) for A (m × n) in CSR arrays and Y (n, k)."""
    m, k = indptr.size - 1, y.shape[1]
    out = np.zeros((m, k))
    for r in range(m):
        for p in range(_u(indptr[r]), _u(indptr[r + 1])):
            j, v = _u(indices[p]), data[p]
            for c in range(k):
                out[r, c] += v * y[j, c]
    return out


@compiled
def product_norm(indptr, indices, data, y):
    """‖A·Y‖₂ for A (m × n) in CSR arrays and Y (n, k ≥ 1): √λ_max of the k × k Gram matrix
    of A·Y."""
    product = times(indptr, indices, data, y)
    return np.sqrt(max(np.linalg.eigvalsh(product.T @ product)[-1], 0.0))


@compiled
def largest_singular_value(indptr, indices, data, t_indptr, t_indices, t_data, start, steps):
    """σ_max(A) = √λ_max(AᵀA) for A (m × n) and Aᵀ in CSR arrays: the largest eigenvalue of the
    tridiagonal T_k of ``steps`` Lanczos steps on AᵀA from ``start`` (n,), a Rayleigh quotient on
    the Krylov space, so never above σ_max (round-off allowing); AᵀA q is taken as Aᵀ(A q)."""
    m, n = indptr.size - 1, start.size
    q = start / np.sqrt(start @ start)
    previous = np.zeros(n)
    alpha = np.zeros(steps)
    beta = np.zeros(steps)
    u = np.empty(m)
    k = 0
    for s in range(min(steps, n)):
        for r in range(m):
            acc = 0.0
            for p in range(_u(indptr[r]), _u(indptr[r + 1])):
                acc += data[p] * q[_u(indices[p])]
            u[r] = acc
        w = np.empty(n)
        for j in range(n):
            acc = 0.0
            for p in range(_u(t_indptr[j]), _u(t_indptr[j + 1])):
                acc += t_data[p] * u[_u(t_indices[p])]
            w[j] = acc
        if s > 0:
            w -= beta[s - 1] * previous
        alpha[s] = q @ w
        w -= alpha[s] * q
        k = s + 1
        b = np.sqrt(w @ w)
        if b == 0.0:  # the Krylov space is invariant: T_k's eigenvalues are exact
            break
        beta[s] = b
        previous, q = q, w / b
    tridiagonal = np.zeros((k, k))
    for i in range(k):
        tridiagonal[i, i] = alpha[i]
        if i + 1 < k:
            tridiagonal[i, i + 1] = beta[i]
            tridiagonal[i + 1, i] = beta[i]
    return np.sqrt(max(np.linalg.eigvalsh(tridiagonal)[-1], 0.0))


@compiled
def ritz_pairs(indptr, indices, data, y):
    """Ritz singular values θ (ascending) and vectors (n, k) of A on span(Y), Y (n, k ≥ 1)
    orthonormal: the singular values of A·Y are those of its triangular factor R (A·Y = QR),
    whose SVD R = U Σ Wᵀ gives the right singular vectors Y W (θ completed with zeros when A
    has fewer rows than Y has columns)."""
    k = y.shape[1]
    r = np.linalg.qr(times(indptr, indices, data, y))[1]
    _, s, wt = np.linalg.svd(r)
    theta = np.zeros(k)
    theta[: s.size] = s
    order = np.argsort(theta, kind="mergesort")
    return theta[order], y @ np.ascontiguousarray(wt[order].T)


@compiled
def project_out_and_orthonormalise(y, known):
    """Q (n, k) of the QR factorisation of (I − K Kᵀ) Y, for Y (n, k ≤ n) and K (n, ρ) orthonormal
    (ρ may be 0); Householder QR (LAPACK geqrf, orgqr)."""
    if known.shape[1]:
        y = y - known @ (known.T @ y)
    return np.linalg.qr(y)[0]


def warm_up() -> None:
    """Compile every kernel for the argument types the sparse route passes them (int64 indices,
    float64 C-contiguous blocks; positions and bars writable or read-only), or load it from
    numba's cache: about 6 s to compile in a fresh environment, 0.2 s from the cache. The
    service calls this when it starts and the container image when it is built, so that no
    request pays for compilation within its time budget."""
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    bars = np.array([[0, 1], [1, 2], [0, 2]], dtype=np.int64)
    frozen_positions, frozen_bars = positions.copy(), bars.copy()
    frozen_positions.flags.writeable = frozen_bars.flags.writeable = False
    for x, e in product((positions, frozen_positions), (bars, frozen_bars)):
        c = compatibility_csr(x, e)
    for x in (positions, frozen_positions):
        normalised(x)
        rigid = rigid_motion_svd(x)[0]
    ct = transpose_csr(*c, positions.size)
    row_gram(*ct, *c)
    block = np.eye(positions.size)[:, :2].copy()
    times(*c, block)
    largest_singular_value(*c, *ct, np.ones(positions.size), 2)
    product_norm(*c, np.ascontiguousarray(rigid))
    ritz_pairs(*c, block)
    uniform_block(np.zeros(1, np.uint64), 2, 2)
    project_out_and_orthonormalise(block, np.zeros((positions.size, 0)))
