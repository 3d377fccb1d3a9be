"""Compiled inner steps of the sparse rank route (solver/analysis/rigidity.py), on CSR arrays.

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
  * ``normal_product``: AᵀA q in one pass; ``largest_singular_value``: σ_max(A) by Lanczos on
    AᵀA; ``product_norm``: ‖A·Y‖₂;
  * ``count_setup``: C, Cᵀ, σ_max and the Gram matrix of the counted side in one call;
  * ``ritz_pairs``: Rayleigh–Ritz singular values and vectors of A on span(Y) (``jacobi_svd``:
    the SVD of a few columns);
  * ``project_out``: (I − K Kᵀ) Y; ``project_out_and_orthonormalise``: Q of (I − K Kᵀ) Y;
  * ``ritz_space``, ``extend_ritz_space``, ``smallest_ritz_pair``, ``ritz_residual``,
    ``relative_error_bound``: the smallest nonzero Ritz pair, its space widened a vector at a
    time, and its error bound;
  * ``null_space_rounds``: the count's whole shift-invert subspace iteration, a generator that
    hands its block to the caller for each shifted solve (CHOLMOD's, solver/analysis/factorisation.py).

The iteration is one generator rather than a Python loop over the steps: at 10² nodes a round
is a few microseconds of arithmetic, and the loop's decisions, array bookkeeping and calls cost
more than the steps (2D network of 100 nodes: 0.12 ms of Python-level work in a 0.36 ms count
against a 0.14 ms CHOLMOD factorisation). Each of its yields is ``(request, block, kept,
dropped, error)``:

  * SOLVE: the caller replaces ``block`` in place by a positive multiple of (AᵀA + δI)⁻¹ block;
  * ORTHONORMALISE: the caller replaces ``block`` in place by an orthonormal basis of its columns
    (blocks too wide for the compiled Householder QR, where its Cholesky QR is faster);
  * ROUND: a round begins (the caller checks its time budget; ``block`` is read only);
  * TOO_MANY: the block would pass ``max_null`` columns (the caller refuses the frame);
  * DONE: ``block`` is the basis, ``kept`` the smallest nonzero Ritz value, ``dropped`` the
    largest zero one, ``error`` kept's relative error bound (``relative_error_bound``); the
    generator ends.

The compiled functions that call one another live in this one module on purpose: numba's disk
cache is invalidated by a change of the file that holds a cached function, not of the files of
the functions it calls.

Hot loops index through np.uint64 casts (``_u``): numba checks every signed index for
wraparound, which made a product with C 1.7× slower than SciPy's at 10⁴ nodes (69 against 40 µs);
with the casts the two are level.

Why compiled: at 10² nodes every step handles a few hundred numbers, and the count made some
forty NumPy and SciPy calls whose per-call overhead (1–60 µs each, more inside a count than
alone: the cache is cold) cost more than the CHOLMOD factorisation itself (0.2–0.7 ms); at 10⁴
nodes and more the same loops run as fast as SciPy's. ``rigidity.warm_up`` compiles them all
ahead of the first request.
"""

from __future__ import annotations

import numpy as np

from zeromode.solver.analysis.compiled import compiled
from zeromode.solver.tolerances import JACOBI_TOL, RITZ_SPACE_RTOL

_u = np.uint64
# null_space_rounds' requests to its caller
SOLVE, ORTHONORMALISE, ROUND, TOO_MANY, DONE = range(5)
# Rayleigh–Ritz takes the SVD of its k × k triangular factor by one-sided Jacobi up to this many
# columns: LAPACK's gesdd costs a few microseconds of set-up at any size (measured, one core,
# inside numba: k = 5 1.7 µs against 4.2 µs, 8 4.4 against 7.1, level at 12, 16 24 against 18).
JACOBI_MAX_COLUMNS = 8
# Sweeps of the one-sided Jacobi SVD before it falls back to LAPACK's (never seen).
JACOBI_MAX_SWEEPS = 30


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
def normal_product(indptr, indices, data, q):
    """AᵀA q (n,) for A (m × n) in CSR arrays and q (n,), in one pass over A's rows:
    AᵀA q = Σ_r a_r (a_r · q), each row read once for both products (a 10⁴-node 2D network:
    0.08 ms against 0.27 ms for A q then Aᵀ(A q) from Aᵀ's arrays)."""
    m, n = indptr.size - 1, q.size
    w = np.zeros(n)
    for r in range(m):
        acc = 0.0
        for p in range(_u(indptr[r]), _u(indptr[r + 1])):
            acc += data[p] * q[_u(indices[p])]
        for p in range(_u(indptr[r]), _u(indptr[r + 1])):
            w[_u(indices[p])] += data[p] * acc
    return w


@compiled
def largest_singular_value(indptr, indices, data, start, steps):
    """σ_max(A) = √λ_max(AᵀA) for A (m × n) in CSR arrays: the largest eigenvalue of the
    tridiagonal T_k of ``steps`` Lanczos steps on AᵀA from ``start`` (n,), a Rayleigh quotient on
    the Krylov space, so never above σ_max (round-off allowing); AᵀA q by ``normal_product``."""
    n = start.size
    q = start / np.sqrt(start @ start)
    previous = np.zeros(n)
    alpha = np.zeros(steps)
    beta = np.zeros(steps)
    k = 0
    for s in range(min(steps, n)):
        w = normal_product(indptr, indices, data, q)
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
def count_setup(positions, edges, count_modes, stream, steps):
    """The sparse count's set-up in one call (one dispatch instead of five at 10² nodes): the
    CSR arrays of C (N_B × dN, ``compatibility_csr``) and of Cᵀ; σ_max(C) by ``steps`` Lanczos
    steps on AᵀA (``largest_singular_value``) from a start of ``uniform_block(stream, n, 1)``; and
    the CSR arrays of AᵀA (``row_gram``), for A = C (n = dN, AᵀA = CᵀC) if ``count_modes``,
    else A = Cᵀ (n = N_B, AᵀA = CCᵀ): the side whose null space the count iterates on."""
    c = compatibility_csr(positions, edges)
    ct = transpose_csr(c[0], c[1], c[2], positions.size)
    a, at = (c, ct) if count_modes else (ct, c)
    n = at[0].size - 1
    start = uniform_block(stream, n, 1).reshape(n)
    sigma_max = largest_singular_value(a[0], a[1], a[2], start, steps)
    return c, ct, sigma_max, row_gram(at[0], at[1], at[2], a[0], a[1], a[2])


@compiled
def ritz_pairs(indptr, indices, data, y):
    """Ritz singular values θ (ascending) and vectors (n, k) of A on span(Y), Y (n, k ≥ 1)
    orthonormal: the singular values of A·Y are those of its triangular factor R (A·Y = QR),
    whose SVD R = U Σ Wᵀ gives the right singular vectors Y W (θ completed with zeros when A
    has fewer rows than Y has columns). R's SVD by one-sided Jacobi when R is square with at
    most JACOBI_MAX_COLUMNS columns, else LAPACK's."""
    k = y.shape[1]
    r = np.linalg.qr(times(indptr, indices, data, y))[1]
    converged = False
    if k <= JACOBI_MAX_COLUMNS and r.shape[0] == k:  # else LAPACK's zeros are exact
        theta, w, converged = jacobi_svd(r)
    if not converged:
        _, s, wt = np.linalg.svd(r)
        theta = np.zeros(k)
        theta[: s.size] = s
        w = np.ascontiguousarray(wt.T)
    order = np.argsort(theta, kind="mergesort")
    return theta[order], y @ np.ascontiguousarray(w[:, order])


@compiled
def jacobi_svd(r):
    """Singular values s (k,), right singular vectors W (k × k, orthogonal) of r (p × k, any
    p ≥ 1), and whether the rotations converged: one-sided Jacobi (Hestenes 1958), plane
    rotations of column pairs, accumulated in W, until the columns of r W are mutually
    orthogonal (|r_jᵀ r_l| ≤ JACOBI_TOL ‖r_j‖ ‖r_l‖ for every pair of columns above JACOBI_TOL
    ‖R‖_F, within JACOBI_MAX_SWEEPS sweeps); s are their norms, in W's column order (zeros, to
    round-off, where p < k). Small singular values above that come out with a small relative
    error, not just small against the largest (Demmel and Veselić 1992)."""
    k = r.shape[1]
    a = np.asfortranarray(r).copy()
    w = np.eye(k)
    converged = jacobi_rotations(a, w)
    norms = np.empty(k)
    for j in range(k):
        norms[j] = np.sqrt(np.sum(a[:, j] * a[:, j]))
    return norms, w, converged


@compiled
def jacobi_rotations(a, w):
    """The rotations of jacobi_svd applied in place: a (p × k, Fortran order) becomes a V with
    mutually orthogonal columns and w (k' × k) becomes w V, V orthogonal; whether they
    converged. A start whose columns are already nearly orthogonal (a warm start) takes a sweep
    or two."""
    p, k = a.shape
    # a column this small against the whole (‖R‖_F, which rotations keep) is round-off: never
    # rotated, as no rotation can make it orthogonal to another beyond that (one row: any two
    # columns are parallel, and the rotation that zeroes one leaves round-off behind)
    negligible = JACOBI_TOL**2 * np.sum(a * a)
    converged = False
    for _ in range(JACOBI_MAX_SWEEPS):
        rotated = False
        for j in range(k - 1):
            for l in range(j + 1, k):
                alpha, beta, gamma = 0.0, 0.0, 0.0
                for i in range(p):
                    alpha += a[i, j] * a[i, j]
                    beta += a[i, l] * a[i, l]
                    gamma += a[i, j] * a[i, l]
                if abs(gamma) <= JACOBI_TOL * np.sqrt(alpha * beta) or min(alpha, beta) <= negligible:
                    continue
                rotated = True
                # the rotation that zeroes the pair's inner product (tangent of the smaller angle)
                zeta = (beta - alpha) / (2.0 * gamma)
                t = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
                c = 1.0 / np.sqrt(1.0 + t * t)
                s = c * t
                for i in range(p):
                    aj, al = a[i, j], a[i, l]
                    a[i, j], a[i, l] = c * aj - s * al, s * aj + c * al
                for i in range(w.shape[0]):
                    wj, wl = w[i, j], w[i, l]
                    w[i, j], w[i, l] = c * wj - s * wl, s * wj + c * wl
        if not rotated:
            converged = True
            break
    return converged


@compiled
def project_out(y, known):
    """(I − K Kᵀ) Y, a new array, for Y (n, k) and K (n, ρ) orthonormal (ρ may be 0)."""
    if known.shape[1] == 0:
        return y.copy()
    return y - known @ (known.T @ y)


@compiled
def project_out_and_orthonormalise(y, known):
    """Q (n, k), C-contiguous, of the QR factorisation of (I − K Kᵀ) Y, for Y (n, k ≤ n) and
    K (n, ρ) orthonormal (ρ may be 0); Householder QR (LAPACK geqrf, orgqr, whose Q is
    column-major)."""
    if known.shape[1]:
        y = project_out(y, known)
    return np.ascontiguousarray(np.linalg.qr(y)[0])


@compiled
def ritz_space(indptr, indices, data, q):
    """The Rayleigh–Ritz factors of A on span(Q), Q (n, k) orthonormal: A·Q = Q_A R (Q_A (m, k)
    orthonormal, R (k, k) upper triangular) and R W = B with W orthogonal and B's columns
    mutually orthogonal, so the Ritz singular values θ are B's column norms and the Ritz
    vectors Q W; returns (Q_A, B, W)."""
    qa, r = np.linalg.qr(times(indptr, indices, data, q))
    b, w = orthogonal_columns(r, np.eye(r.shape[1]))
    return np.ascontiguousarray(qa), b, w


@compiled
def orthogonal_columns(b, w):
    """(B V, W V) with B V's columns mutually orthogonal (V orthogonal), for B (k, k) and W
    (k, k): one-sided Jacobi from B (warm: a sweep or two when B's columns are nearly so
    already), LAPACK's SVD if it does not converge."""
    a = np.asfortranarray(b).copy()
    v = np.asfortranarray(w).copy()
    if not jacobi_rotations(a, v):
        u, sigma, vt = np.linalg.svd(b)
        return np.ascontiguousarray(u * sigma), w @ np.ascontiguousarray(vt.T)
    return np.ascontiguousarray(a), np.ascontiguousarray(v)


@compiled
def smallest_ritz_pair(indptr, indices, data, q, b, w):
    """The smallest Ritz singular value θ of A on span(Q), its Ritz vector u (n,) and the
    residual ‖AᵀA u − θ² u‖, from the factors of ritz_space (θ is B's smallest column norm)."""
    k = b.shape[1]
    theta = np.empty(k)
    for j in range(k):
        theta[j] = np.sqrt(np.sum(b[:, j] * b[:, j]))
    j = np.argmin(theta)
    u = q @ np.ascontiguousarray(w[:, j])
    return theta[j], u, ritz_residual(indptr, indices, data, theta[j], u)


@compiled
def ritz_residual(indptr, indices, data, theta, u):
    """‖AᵀA u − θ² u‖ for a Ritz pair (θ, u (n,)) of A (m × n) in CSR arrays."""
    residual = normal_product(indptr, indices, data, u) - theta * theta * u
    return np.sqrt(residual @ residual)


@compiled
def extend_ritz_space(indptr, indices, data, null, q, qa, b, w, x):
    """The factors of ritz_space for [Q, x̂], x̂ the part of x (n,) orthogonal to the null
    vectors ``null`` (n, z) and to Q (n, k), normalised (two Gram–Schmidt passes each), updated
    rather than recomputed: A x̂ = Q_A c + ρ q̂ gives A [Q W, x̂] = [Q_A, q̂] [[B, c], [0, ρ]],
    whose columns are re-orthogonalised from that warm start. Returns (Q', Q_A', B', W', grew),
    ``grew`` False (arrays unchanged) when x lies in span(null, Q) to round-off (the space is
    invariant: its Ritz values are exact)."""
    n, k = q.shape
    size = np.sqrt(x @ x)
    for _ in range(2):
        x = x - null @ (null.T @ x)
        x = x - q @ (q.T @ x)
    norm = np.sqrt(x @ x)
    if norm <= RITZ_SPACE_RTOL * size:
        return q, qa, b, w, False
    x = x / norm
    ax = times(indptr, indices, data, x.reshape(-1, 1)).ravel()
    grown_b = np.zeros((k + 1, k + 1))
    grown_b[:k, :k] = b
    for _ in range(2):
        c = qa.T @ ax
        ax = ax - qa @ c
        grown_b[:k, k] += c
    grown_b[k, k] = np.sqrt(ax @ ax)
    grown_q = np.empty((n, k + 1))
    grown_q[:, :k] = q
    grown_q[:, k] = x
    grown_qa = np.empty((qa.shape[0], k + 1))
    grown_qa[:, :k] = qa
    grown_qa[:, k] = ax / grown_b[k, k] if grown_b[k, k] > 0.0 else ax
    grown_w = np.zeros((k + 1, k + 1))
    grown_w[:k, :k] = w
    grown_w[k, k] = 1.0
    grown_b, grown_w = orthogonal_columns(grown_b, grown_w)
    return grown_q, grown_qa, grown_b, grown_w, True


@compiled
def relative_error_bound(theta, residual):
    """1 − √(1 − ρ/θ²) (1 when ρ ≥ θ²): for a Ritz pair (θ², u) of AᵀA with residual
    ρ = ‖AᵀA u − θ² u‖, some eigenvalue λ of AᵀA lies within ρ of θ² (Weyl), so some singular
    value σ = √λ of A lies within this fraction below θ (and at most as far above)."""
    if theta <= 0.0 or residual >= theta * theta:
        return 1.0
    return 1.0 - np.sqrt(1.0 - residual / (theta * theta))


@compiled
def null_space_rounds(indptr, indices, data, known, width, stream, tol, shift,
                      settled, damped, householder_max, max_null, first_steps, max_rounds, gap_rtol, max_polish_steps):
    """Orthonormal basis of N(A) ⊖ span(K), yielding as the module docstring says.

    A: m × n in CSR arrays; known: K (n × ρ, C-contiguous, orthonormal); width: the block's
    starting width (a guess at the dimension plus oversampling); stream: the SplitMix64 state
    of the starting columns (sparse_kernels.uniform_block); tol: the rank's threshold on the
    Ritz values; shift: δ.

    Shift-invert subspace iteration: each step applies (AᵀA + δI)⁻¹, which damps a singular
    direction σ by δ/(σ² + δ) relative to the null space, and re-orthonormalises the block
    (⟂ K). After each round a Rayleigh–Ritz step on A itself gives the Ritz singular values
    θ ≥ σ on the block; those with θ ≤ tol are null, and once θ ≤ ``settled``·tol they are
    locked: kept aside and projected out of the block, which goes on with its other columns
    only (the null space is invariant under the shifted inverse, so this spans what iterating
    the whole block would, without solving for vectors already found). A null direction not yet
    found shows up as a small nonzero θ that keeps falling by δ/(σ² + δ) per step, so the rounds
    (``first_steps`` steps in the first, one after) stop only when a round finds no new null
    vector and no θ it watches fell by 10 % or more from the θ in the same place a round before
    (locked ones leave the block, settled). It watches the null θ not yet locked and the
    nonzero θ with θ² < ``damped``·δ (in a wider block a falling θ is a block still turning
    towards the directions the shift amplifies, and a null vector may be mixed into a smaller θ
    that does not fall; a null θ not yet settled that still falls is a null vector still
    shedding singular directions the shift barely damps, whose θ would be reported as σ_{r+1}:
    a 10⁵-node network started at its guessed width reported 1.4e-11 against σ_r 7.7e-11 when
    only the nonzero θ were watched, 3e-14 watching all).

    Two kinds of block may miss part of the null space, and take fresh random directions before
    the rounds start again: one whose columns are all null takes as many as its width (locked
    columns included), and one whose largest θ has θ² < δ (all of it lies in directions the
    shift barely damps, which may extend beyond it) as many as it has such nonzero θ (doubling
    there added columns past the first damped one: 2D 10⁴-node networks, column solves over
    seeds 0–7, 128 against 137). The count is that of a last Rayleigh–Ritz step on the locked
    and the other columns together, which by interlacing never exceeds the null space's
    dimension; when every locked column was locked by the latest Rayleigh–Ritz step and the
    other columns are that step's Ritz vectors, the two span the same space and that step's
    pairs are its pairs (one product with A and one QR saved).

    σ_r's Ritz pair (θ, u), the smallest of that step's nonzero ones, comes with the Weyl bound
    of its residual (``relative_error_bound``). While that bound is above ``gap_rtol`` (and for
    at most ``max_polish_steps`` steps) the span of the nonzero Ritz vectors takes the shifted
    inverse of u (⟂ the null vectors), and (θ, u) become the smallest Ritz pair of the wider
    space: from one vector that is Lanczos on the shifted inverse, whose extreme Ritz value
    converges at a rate set by the square root of the relative gap, where subspace iteration's
    is set by the gap itself.
    """
    n = known.shape[0]
    base = known.shape[1]
    room = n - base
    if room == 0:
        yield DONE, np.zeros((n, 0)), 0.0, 0.0, 0.0
        return
    active = known  # the known columns and the locked null vectors
    y = project_out(uniform_block(stream, n, min(room, width)), active)
    steps = first_steps
    watching = False  # whether the previous round's null count and θ are there to compare
    previous_null = 0
    previous_theta = np.zeros(0)
    latest = False  # whether the latest Rayleigh–Ritz step's pairs span every column
    latest_theta = np.zeros(0)
    latest_y = y
    for _ in range(max_rounds):
        yield ROUND, y, 0.0, 0.0, 0.0
        for _ in range(steps):
            yield SOLVE, y, 0.0, 0.0, 0.0
            if y.shape[1] <= householder_max:
                y = project_out_and_orthonormalise(y, active)
            else:
                y = project_out(y, active)
                yield ORTHONORMALISE, y, 0.0, 0.0, 0.0
        older_locks = active.shape[1] > base
        theta, y = ritz_pairs(indptr, indices, data, y)
        latest = not older_locks
        latest_theta, latest_y = theta, y
        newly = 0
        while newly < theta.size and theta[newly] <= settled * tol:
            newly += 1
        if newly:
            active = np.hstack((active, np.ascontiguousarray(y[:, :newly])))
            theta, y = theta[newly:].copy(), np.ascontiguousarray(y[:, newly:])
            if watching:  # compare what stays with the same places a round before
                previous_theta = previous_theta[newly:].copy()
        locked = active.shape[1] - base
        z = 0
        while z < theta.size and theta[z] <= tol:
            z += 1
        null, width = locked + z, locked + y.shape[1]
        if null == width or theta[-1] ** 2 < shift:
            if width == room:
                break
            if width >= max_null:
                yield TOO_MANY, y, 0.0, 0.0, 0.0
                return
            if null == width:
                more = width
            else:
                more = 0
                for value in theta:
                    if value > tol and value**2 < shift:
                        more += 1
            fresh = project_out(uniform_block(stream, n, min(more, room - width)), active)
            y = np.hstack((y, fresh - y @ (y.T @ fresh)))
            steps, watching, latest = first_steps, False, False
            continue
        if watching and null == previous_null:
            still = True
            for i in range(theta.size):
                if theta[i] < 0.9 * previous_theta[i] and (theta[i] <= tol or theta[i] ** 2 < damped * shift):
                    still = False
                    break
            if still:
                break
        steps, watching, previous_null, previous_theta = 1, True, null, theta
    if latest:
        theta, y = latest_theta, latest_y
    else:
        theta, y = ritz_pairs(indptr, indices, data, np.hstack((np.ascontiguousarray(active[:, base:]), y)))
    z = 0
    while z < theta.size and theta[z] <= tol:
        z += 1
    kept = theta[z] if z < theta.size else 0.0
    dropped = theta[z - 1] if z > 0 else 0.0
    error = 0.0
    if z < theta.size:  # σ_r's Ritz pair and its bound
        u = np.ascontiguousarray(y[:, z])
        error = relative_error_bound(kept, ritz_residual(indptr, indices, data, kept, u))
    if error > gap_rtol and max_polish_steps > 0:  # from the span of the nonzero Ritz vectors
        null = np.hstack((known, np.ascontiguousarray(y[:, :z])))
        q = np.ascontiguousarray(y[:, z:])
        qa, b, w = ritz_space(indptr, indices, data, q)
        for _ in range(max_polish_steps):
            if error <= gap_rtol:
                break
            yield ROUND, q, 0.0, 0.0, 0.0
            x = u.reshape(n, 1).copy()
            yield SOLVE, x, 0.0, 0.0, 0.0
            q, qa, b, w, grew = extend_ritz_space(indptr, indices, data, null, q, qa, b, w, x.ravel())
            if not grew:
                break
            kept, u, residual = smallest_ritz_pair(indptr, indices, data, q, b, w)
            error = relative_error_bound(kept, residual)
    yield DONE, np.ascontiguousarray(y[:, :z]), kept, dropped, error
