"""The numba kernels of the sparse route (solver/analysis/sparse_kernels.py), against SciPy and numpy.

Every kernel is checked through a route that shares none of its code: C is built densely from
the paper's definition (row e holds x_i − x_j in node i's d columns, the negative in node j's);
transposes and products against ``scipy.sparse.csr_matrix`` (``.T``, ``@``, ``eliminate_zeros``)
and dense numpy products; σ_max, ‖A·Y‖₂, Ritz values, projections and the rigid motions' SVD
against ``np.linalg.svd``, ``np.linalg.norm`` and rigid motions built with cross products. Matrices with integer entries in {−2, −1, 1, 2} and frames on an integer grid
make sums that cancel exactly, so the kernels' dropping of exact zeros is checked bit for bit;
a 2025-node triangulated lattice checks the Gram product at a size where a slot reused across
rows once made CᵀC indefinite while small cases passed.
"""

import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from zeromode.solver.analysis.normalisation import normalised
from zeromode.solver.analysis.sparse_kernels import (
    DONE,
    ORTHONORMALISE,
    ROUND,
    SOLVE,
    TOO_MANY,
    compatibility_csr,
    count_setup,
    extend_ritz_space,
    jacobi_svd,
    largest_singular_value,
    normal_product,
    null_space_rounds,
    product_norm,
    project_out_and_orthonormalise,
    relative_error_bound,
    rigid_motion_svd,
    ritz_pairs,
    ritz_space,
    row_gram,
    smallest_ritz_pair,
    times,
    transpose_csr,
    uniform_block,
)

KERNEL_SETTINGS = settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
seeds = st.integers(0, 2**32 - 1)


# --- helpers: CSR arrays in and out, dense references ------------------------------------------


def arrays_of(a) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The CSR arrays of a (dense or SciPy) matrix as the kernels take them: sorted columns,
    int64 indices, float64 data, all C-contiguous (numba compiles one version per signature)."""
    a = sp.csr_matrix(a)
    a.sort_indices()
    return (
        np.ascontiguousarray(a.indptr, dtype=np.int64),
        np.ascontiguousarray(a.indices, dtype=np.int64),
        np.ascontiguousarray(a.data, dtype=np.float64),
    )


def dense_of(indptr, indices, data, ncols: int) -> np.ndarray:
    """The dense matrix of CSR arrays by plain numpy (duplicate entries would add up)."""
    rows = np.repeat(np.arange(indptr.size - 1), np.diff(indptr))
    out = np.zeros((indptr.size - 1, ncols))
    np.add.at(out, (rows, indices), data)
    return out


def scipy_of(arrays, shape) -> sp.csr_matrix:
    """A SciPy matrix holding the kernels' (indptr, indices, data) as they are."""
    indptr, indices, data = arrays
    return sp.csr_matrix((data, indices, indptr), shape=shape)


def row_of_each_entry(indptr) -> np.ndarray:
    return np.repeat(np.arange(indptr.size - 1), np.diff(indptr))


def columns_strictly_ascending(indptr, indices) -> bool:
    """Within every row the column indices increase strictly (sorted, no duplicates)."""
    rows = row_of_each_entry(indptr)
    same_row = rows[1:] == rows[:-1]
    return bool(np.all(np.diff(indices)[same_row] > 0))


def no_duplicate_columns(indptr, indices) -> bool:
    rows = row_of_each_entry(indptr)
    pairs = np.stack([rows, indices], axis=1)
    return np.unique(pairs, axis=0).shape[0] == pairs.shape[0]


def compatibility_dense(positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """C (N_B × dN) from the definition: row e = x_i − x_j in node i's d columns, x_j − x_i in
    node j's, for bar e = (i, j) in whichever orientation it is given."""
    n, d = positions.shape
    c = np.zeros((len(edges), d * n))
    for e, (i, j) in enumerate(edges):
        c[e, d * i : d * i + d] = positions[i] - positions[j]
        c[e, d * j : d * j + d] = positions[j] - positions[i]
    return c


def random_integer_sparse(rng, m: int, n: int, density: float) -> np.ndarray:
    """A dense m × n matrix, entries in {−2, −1, 1, 2} at random places (so sums of products
    are exact integers and cancel exactly), with about a quarter of rows and columns emptied."""
    a = rng.choice(np.array([-2.0, -1.0, 1.0, 2.0]), size=(m, n))
    a[rng.random((m, n)) >= density] = 0.0
    a[rng.random(m) < 0.25, :] = 0.0
    a[:, rng.random(n) < 0.25] = 0.0
    return a


@st.composite
def integer_matrices(draw, max_rows=40, max_cols=40):
    rng = np.random.default_rng(draw(seeds))
    m, n = draw(st.integers(1, max_rows)), draw(st.integers(1, max_cols))
    return random_integer_sparse(rng, m, n, draw(st.sampled_from([0.05, 0.15, 0.4, 0.8])))


@st.composite
def float_matrices(draw, max_rows=30, max_cols=30):
    """Sparse Gaussian matrices with some empty rows and columns."""
    rng = np.random.default_rng(draw(seeds))
    m, n = draw(st.integers(1, max_rows)), draw(st.integers(1, max_cols))
    a = rng.standard_normal((m, n))
    a[rng.random((m, n)) >= draw(st.sampled_from([0.1, 0.3, 0.7, 1.0]))] = 0.0
    a[rng.random(m) < 0.2, :] = 0.0
    a[:, rng.random(n) < 0.2] = 0.0
    return a


def triangulated_grid(side: int) -> tuple[np.ndarray, np.ndarray]:
    """side² nodes at integer points, bars horizontal, vertical and one diagonal a square:
    every bar vector has an exact zero or equal components, so blocks u uᵀ cancel exactly."""
    node = np.arange(side * side).reshape(side, side)
    ii, jj = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    positions = np.stack([ii.ravel(), jj.ravel()], axis=1).astype(float)
    edges = np.concatenate(
        [
            np.stack([node[:-1, :].ravel(), node[1:, :].ravel()], axis=1),
            np.stack([node[:, :-1].ravel(), node[:, 1:].ravel()], axis=1),
            np.stack([node[1:, 1:].ravel(), node[:-1, :-1].ravel()], axis=1),  # i > j
        ]
    ).astype(np.int64)
    return positions, edges


def check_gram(a, t_arrays=None, rtol=0.0):
    """row_gram on A against SciPy's A @ Aᵀ with exact zeros eliminated: same pattern row by row
    (after sorting), values equal (to rtol of the largest entry), no stored 0.0, no duplicate
    column in a row, symmetric. Aᵀ is SciPy's unless t_arrays are given."""
    a = sp.csr_matrix(a)
    indptr, indices, data = arrays_of(a)
    if t_arrays is None:
        t_arrays = arrays_of(a.T.tocsr())
    g_indptr, g_indices, g_data = row_gram(indptr, indices, data, *t_arrays)
    m = a.shape[0]

    assert g_indptr.shape == (m + 1,) and g_indptr[0] == 0
    assert g_indices.size == g_data.size == g_indptr[-1]
    assert not np.any(g_data == 0.0), "an exact zero is stored"
    assert no_duplicate_columns(g_indptr, g_indices), "a column repeats within a row"
    assert g_indices.size == 0 or (g_indices.min() >= 0 and g_indices.max() < m)

    reference = (a @ a.T).tocsr()
    reference.eliminate_zeros()
    reference.sort_indices()
    ours = scipy_of((g_indptr, g_indices, g_data), (m, m))
    ours.sort_indices()
    assert np.array_equal(ours.indptr, reference.indptr), "row lengths differ from SciPy's"
    assert np.array_equal(ours.indices, reference.indices), "pattern differs from SciPy's"
    scale = np.abs(reference.data).max(initial=0.0)
    np.testing.assert_allclose(ours.data, reference.data, rtol=0, atol=rtol * scale)
    asymmetry = abs(ours - ours.T).max() if m else 0.0
    assert asymmetry <= rtol * scale
    return ours


def orthonormal(rng, n: int, k: int) -> np.ndarray:
    return np.ascontiguousarray(np.linalg.qr(rng.standard_normal((n, k)))[0])


# --- compatibility_csr ------------------------------------------------------------------------


@KERNEL_SETTINGS
@given(
    st.sampled_from([2, 3]),
    st.integers(2, 12),
    st.integers(0, 25),
    st.booleans(),
    seeds,
)
def test_compatibility_matches_the_definition(d, n, n_bars, on_grid, seed):
    """C from the kernel equals C built densely from the paper's definition, for bars given as
    (i, j) with i < j or i > j at random; every row holds 2d entries, columns ascending."""
    rng = np.random.default_rng(seed)
    if on_grid:  # shared coordinates: differences exactly 0 in some axes
        positions = rng.integers(-2, 3, size=(n, d)).astype(float)
    else:
        positions = rng.standard_normal((n, d))
    i = rng.integers(0, n, n_bars)
    j = (i + rng.integers(1, n, n_bars)) % n  # j != i, either side of i
    edges = np.ascontiguousarray(np.stack([i, j], axis=1), dtype=np.int64)

    indptr, indices, data = compatibility_csr(np.ascontiguousarray(positions), edges)
    assert indptr.dtype == indices.dtype == np.int64 and data.dtype == np.float64
    assert np.array_equal(indptr, 2 * d * np.arange(n_bars + 1))
    assert columns_strictly_ascending(indptr, indices)
    np.testing.assert_array_equal(
        dense_of(indptr, indices, data, d * n), compatibility_dense(positions, edges)
    )


def test_compatibility_is_the_same_for_either_orientation():
    """Flipping every bar (i, j) → (j, i) leaves C unchanged, arrays and all."""
    rng = np.random.default_rng(7)
    positions = rng.standard_normal((6, 3))
    edges = np.array([[0, 1], [4, 2], [5, 0], [3, 5]], dtype=np.int64)
    forward = compatibility_csr(positions, edges)
    backward = compatibility_csr(positions, np.ascontiguousarray(edges[:, ::-1]))
    for a, b in zip(forward, backward, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(
        dense_of(*forward, 18), compatibility_dense(positions, edges[:, ::-1])
    )


# --- rigid_motion_svd ------------------------------------------------------------------------


def rigid_generators(positions: np.ndarray) -> np.ndarray:
    """dN × d(d+1)/2 generators of the rigid motions, node-major: the d translations, then the
    rotations about the axes ω, u_i = ω × x_i (in 2D the one rotation u_i = (−y_i, x_i))."""
    n, d = positions.shape
    columns = [np.tile(np.eye(d)[a], n) for a in range(d)]
    if d == 2:
        columns.append(np.stack([-positions[:, 1], positions[:, 0]], axis=1).ravel())
    else:
        columns += [np.cross(np.eye(3)[a], positions).ravel() for a in range(3)]
    return np.stack(columns, axis=1)


@KERNEL_SETTINGS
@given(
    st.sampled_from([2, 3]), st.integers(1, 10), st.sampled_from(["random", "line", "grid"]), seeds
)
def test_rigid_motion_svd_spans_the_rigid_motions(d, n, kind, seed):
    """U (dN × d(d+1)/2) is orthonormal, s are the singular values (descending) of the rigid
    motion generators built with cross products (the same up to column signs), and the columns
    of U belonging to nonzero s span the same space as those generators (equal projectors);
    collinear and grid points make some s vanish."""
    rng = np.random.default_rng(seed)
    if kind == "random":
        positions = rng.standard_normal((n, d))
    elif kind == "line":
        positions = rng.standard_normal((n, 1)) * rng.standard_normal(d) + rng.standard_normal(d)
    else:
        positions = rng.integers(-1, 2, size=(n, d)).astype(float)
    u, s = rigid_motion_svd(np.ascontiguousarray(positions))
    g = rigid_generators(positions)
    size = d * (d + 1) // 2
    assert u.shape == (d * n, min(d * n, size)) and s.shape == (min(d * n, size),)

    u_ref, s_ref, _ = np.linalg.svd(g, full_matrices=False)
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=1e-12 * s_ref[0])
    np.testing.assert_allclose(u.T @ u, np.eye(u.shape[1]), rtol=0, atol=1e-12)
    r = int(np.sum(s_ref > 1e-8 * s_ref[0]))
    np.testing.assert_allclose(
        u[:, :r] @ u[:, :r].T, u_ref[:, :r] @ u_ref[:, :r].T, rtol=0, atol=1e-8
    )


# --- transpose_csr ----------------------------------------------------------------------------


def check_transpose(a: np.ndarray):
    indptr, indices, data = arrays_of(a)
    m, n = a.shape
    t_indptr, t_indices, t_data = transpose_csr(indptr, indices, data, n)
    reference = sp.csr_matrix(a).T.tocsr()
    assert t_indptr.shape == (n + 1,)
    assert np.array_equal(t_indptr, reference.indptr.astype(np.int64))
    assert columns_strictly_ascending(t_indptr, t_indices)
    assert t_indices.size == 0 or (t_indices.min() >= 0 and t_indices.max() < m)
    np.testing.assert_array_equal(dense_of(t_indptr, t_indices, t_data, m), reference.toarray())


@KERNEL_SETTINGS
@given(float_matrices(max_rows=40, max_cols=40))
def test_transpose_matches_scipy(a):
    """Aᵀ from the kernel equals SciPy's A.T.tocsr() exactly (values only move), with the same
    row lengths and columns ascending in every row; empty rows and columns included."""
    check_transpose(a)


@pytest.mark.parametrize(
    "a",
    [
        np.zeros((3, 4)),  # nothing stored
        np.array([[0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 2.0, 0.0, -1.0, 0.0]]),  # empty row, columns
        np.array([[1.0], [0.0], [3.0]]),
        np.eye(1, 6, 5),  # only the last column
    ],
)
def test_transpose_edge_cases(a):
    """Empty matrices, empty leading and trailing rows and columns."""
    check_transpose(a)


# --- row_gram ---------------------------------------------------------------------------------


@KERNEL_SETTINGS
@given(integer_matrices())
def test_row_gram_matches_scipy_with_exact_cancellation(a):
    """A Aᵀ from the kernel equals SciPy's product bit for bit (integer entries: every sum is
    exact) with SciPy's pattern once exact zeros are eliminated: no stored 0.0, no column twice
    in a row, symmetric. Aᵀ given both by SciPy and by transpose_csr."""
    check_gram(a)
    indptr, indices, data = arrays_of(a)
    ours = check_gram(a, transpose_csr(indptr, indices, data, a.shape[1]))
    np.testing.assert_array_equal(ours.toarray(), a @ a.T)


@KERNEL_SETTINGS
@given(float_matrices())
def test_row_gram_matches_the_dense_product(a):
    """For Gaussian entries (no exact cancellation but for empty rows) A Aᵀ equals a @ a.T."""
    indptr, indices, data = arrays_of(a)
    g = row_gram(indptr, indices, data, *arrays_of(sp.csr_matrix(a).T.tocsr()))
    assert not np.any(g[2] == 0.0)
    assert no_duplicate_columns(g[0], g[1])
    np.testing.assert_allclose(dense_of(*g, a.shape[0]), a @ a.T, rtol=0, atol=1e-12)


def test_row_gram_cancels_exactly_in_small_rows():
    """Rows (1, 1, 0), (1, −1, 0), (0, 0, 1): their products cancel to exact zeros (0 at (0, 1),
    (1, 0) and all of row and column 2 but the diagonal), which are not stored."""
    a = np.array([[1.0, 1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    ours = check_gram(a)
    assert ours.nnz == 3
    np.testing.assert_array_equal(ours.toarray(), np.diag([2.0, 2.0, 1.0, 0.0]))


@pytest.mark.parametrize("scale", [1.0, 0.25])
def test_row_gram_on_a_triangulated_lattice(scale):
    """On a 45 × 45 triangulated grid (2025 nodes, 5896 bars, Cᵀ by transpose_csr), CᵀC and CCᵀ
    equal SciPy's products to 1e-12 relative with SciPy's pattern after eliminate_zeros: the
    axis-aligned bars' blocks u uᵀ are mostly exact zeros, none stored; a slot reused across
    rows (a past bug) made CᵀC indefinite at this size while small cases passed."""
    positions, edges = triangulated_grid(45)
    positions = np.ascontiguousarray(scale * positions)
    c_arrays = compatibility_csr(positions, edges)
    ndof = positions.size
    c = scipy_of(c_arrays, (len(edges), ndof))
    np.testing.assert_array_equal(c.toarray(), compatibility_dense(positions, edges))
    t_arrays = transpose_csr(*c_arrays, ndof)

    ctc = check_gram(c.T.tocsr(), c_arrays, rtol=1e-12)  # A = Cᵀ, Aᵀ = C
    assert ctc.shape == (ndof, ndof)
    # fewer entries than the structural 2 × 2 blocks (4 a node, 8 a bar): zeros were dropped
    assert ctc.nnz < 4 * len(positions) + 8 * len(edges)
    ours = scipy_of(row_gram(*t_arrays, *c_arrays), (ndof, ndof))
    np.testing.assert_array_equal(ours.toarray(), (c.T @ c).toarray())  # exact: dyadic values

    cct = check_gram(c, t_arrays, rtol=1e-12)  # A = C, Aᵀ by transpose_csr
    assert cct.shape == (len(edges), len(edges))


# --- times ------------------------------------------------------------------------------------


@KERNEL_SETTINGS
@given(float_matrices(), st.integers(1, 6), seeds)
def test_times_matches_the_dense_product(a, k, seed):
    """A·Y for Y (n, k), k = 1…6, equals the dense a @ y; empty rows give zero rows."""
    y = np.random.default_rng(seed).standard_normal((a.shape[1], k))
    out = times(*arrays_of(a), y)
    assert out.shape == (a.shape[0], k)
    np.testing.assert_allclose(out, a @ y, rtol=0, atol=1e-12 * max(1.0, np.abs(a @ y).max()))
    np.testing.assert_array_equal(out[~a.any(axis=1)], 0.0)


@KERNEL_SETTINGS
@given(float_matrices(), seeds)
def test_normal_product_matches_the_two_dense_products(a, seed):
    """AᵀA q in one pass over A's rows equals the dense a.T @ (a @ q); zero where A has an empty
    column."""
    q = np.random.default_rng(seed).standard_normal(a.shape[1])
    out = normal_product(*arrays_of(a), q)
    expected = a.T @ (a @ q)
    assert out.shape == (a.shape[1],)
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12 * max(1.0, np.abs(expected).max()))
    np.testing.assert_array_equal(out[~a.any(axis=0)], 0.0)


# --- product_norm -----------------------------------------------------------------------------


@KERNEL_SETTINGS
@given(float_matrices(), st.integers(1, 6), seeds)
def test_product_norm_is_the_spectral_norm(a, k, seed):
    """‖A·Y‖₂ equals np.linalg.norm(a @ y, 2) (its largest singular value) to 1e-12 relative;
    0 for A·Y = 0."""
    y = np.random.default_rng(seed).standard_normal((a.shape[1], k))
    expected = np.linalg.norm(a @ y, 2)
    value = product_norm(*arrays_of(a), y)
    assert value == pytest.approx(expected, rel=1e-12, abs=1e-300)


# --- largest_singular_value -------------------------------------------------------------------


def sigma_max(a, steps: int, seed: int) -> float:
    a = sp.csr_matrix(a)
    start = np.random.default_rng(seed).standard_normal(a.shape[1])
    return largest_singular_value(*arrays_of(a), start, steps)


@KERNEL_SETTINGS
@given(float_matrices(max_rows=25, max_cols=25), seeds)
def test_largest_singular_value(a, seed):
    """Lanczos on AᵀA gives a Rayleigh quotient of the Krylov space, so √θ never exceeds
    σ_max = np.linalg.svd(a)[0] beyond round-off, for any number of steps; with steps ≥ n it
    is σ_max to 1e-10 relative."""
    reference = np.linalg.svd(a, compute_uv=False)[0]
    n = a.shape[1]
    for steps in (1, 2, 5, n, n + 3):
        value = sigma_max(a, steps, seed)
        assert np.isfinite(value) and value >= 0.0
        assert value <= reference * (1 + 1e-12) + 1e-300
    assert sigma_max(a, n, seed) == pytest.approx(reference, rel=1e-10, abs=1e-300)


def test_largest_singular_value_of_special_matrices():
    """The zero matrix gives 0 (not NaN); a rank-one u vᵀ gives ‖u‖‖v‖ to round-off from two
    steps (the Krylov space from q is span{q, v}); a diagonal matrix gives its largest |entry|."""
    assert sigma_max(np.zeros((4, 6)), 6, 0) == 0.0
    assert sigma_max(np.zeros((1, 1)), 3, 0) == 0.0
    rng = np.random.default_rng(5)
    u, v = rng.standard_normal(7), rng.standard_normal(9)
    v[[2, 5]] = 0.0
    rank_one = np.outer(u, v)
    expected = np.linalg.norm(u) * np.linalg.norm(v)
    for steps in (2, 3, 9):
        assert sigma_max(rank_one, steps, 1) == pytest.approx(expected, rel=1e-12)
    diagonal = np.diag([0.5, -3.0, 2.0, 0.0, 1.0])
    assert sigma_max(diagonal, 5, 2) == pytest.approx(3.0, rel=1e-12)


# --- ritz_pairs -------------------------------------------------------------------------------


def check_ritz(a: np.ndarray, y: np.ndarray):
    k = y.shape[1]
    theta, v = ritz_pairs(*arrays_of(a), y)
    assert theta.shape == (k,) and v.shape == y.shape
    assert np.all(np.diff(theta) >= 0.0), "θ not ascending"
    reference = np.zeros(k)
    s = np.linalg.svd(a @ y, compute_uv=False)
    reference[k - s.size :] = np.sort(s)  # padded with zeros below
    scale = max(1.0, reference[-1])
    np.testing.assert_allclose(theta, reference, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(v.T @ v, np.eye(k), rtol=0, atol=1e-12)
    assert np.linalg.norm(v - y @ (y.T @ v)) <= 1e-12, "V leaves span(Y)"
    # Rayleigh–Ritz: (A V)ᵀ (A V) = diag(θ²), so ‖A v_i‖ = θ_i and A v_i ⟂ A v_j
    av = a @ v
    np.testing.assert_allclose(np.linalg.norm(av, axis=0), theta, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(av.T @ av, np.diag(theta**2), rtol=0, atol=1e-12 * scale**2)


@KERNEL_SETTINGS
@given(float_matrices(max_rows=15, max_cols=15), st.data())
def test_ritz_pairs_match_the_svd_on_the_subspace(a, data):
    """For Y (n, k) orthonormal, θ are the singular values of a @ y ascending (zeros added when
    A has fewer rows than k); V is orthonormal, inside span(Y), and (AV)ᵀ(AV) = diag(θ²)."""
    n = a.shape[1]
    k = data.draw(st.integers(1, n))
    check_ritz(a, orthonormal(np.random.default_rng(data.draw(seeds)), n, k))


@pytest.mark.parametrize("shape", [(12, 8), (3, 8), (8, 8), (1, 5)])
def test_ritz_pairs_on_the_whole_space(shape):
    """k = n: Y spans everything, so θ are A's singular values (padded with zeros when A has
    fewer rows than columns) and V are right singular vectors."""
    rng = np.random.default_rng(sum(shape))
    a = rng.standard_normal(shape)
    a[rng.random(shape) < 0.3] = 0.0
    n = shape[1]
    y = orthonormal(rng, n, n)
    check_ritz(a, y)
    theta, _ = ritz_pairs(*arrays_of(a), y)
    expected = np.zeros(n)
    s = np.linalg.svd(a, compute_uv=False)
    expected[n - s.size :] = np.sort(s)
    np.testing.assert_allclose(theta, expected, rtol=0, atol=1e-12 * expected[-1])


def test_ritz_pairs_with_fewer_rows_than_columns_of_y():
    """A with 2 rows and Y with 4 columns: θ has two exact zeros first."""
    rng = np.random.default_rng(11)
    a = rng.standard_normal((2, 10))
    y = orthonormal(rng, 10, 4)
    check_ritz(a, y)
    theta, _ = ritz_pairs(*arrays_of(a), y)
    assert theta[0] == theta[1] == 0.0 and theta[2] > 0.0


# --- project_out_and_orthonormalise -----------------------------------------------------------


@KERNEL_SETTINGS
@given(st.integers(1, 20), st.data())
def test_project_out_and_orthonormalise(n, data):
    """Q is orthonormal, orthogonal to K (KᵀQ = 0), and spans (I − K Kᵀ) Y: its projector equals
    the one from np.linalg.svd's left singular vectors of (I − K Kᵀ) Y, and that block equals
    Q Qᵀ of itself. K may have no columns. One projection pass leaves KᵀQ at round-off times
    κ = ‖Y‖ / σ_min((I − K Kᵀ) Y) (large when Y nearly lies in span(K)), and the two routes'
    subspaces differ by as much, so those two checks are scaled by κ."""
    rng = np.random.default_rng(data.draw(seeds))
    rho = data.draw(st.integers(0, n - 1))
    k = data.draw(st.integers(1, n - rho))
    y = np.ascontiguousarray(rng.standard_normal((n, k)))
    known = orthonormal(rng, n, rho) if rho else np.zeros((n, 0))
    q = project_out_and_orthonormalise(y, known)

    assert q.shape == (n, k)
    np.testing.assert_allclose(q.T @ q, np.eye(k), rtol=0, atol=1e-12)
    projected = y - known @ (known.T @ y)
    u, s, _ = np.linalg.svd(projected, full_matrices=False)
    kappa = np.linalg.norm(y, 2) / s[-1]
    np.testing.assert_allclose(known.T @ q, 0.0, rtol=0, atol=1e-14 * n * kappa)
    np.testing.assert_allclose(q @ q.T, u @ u.T, rtol=0, atol=1e-14 * n * kappa)
    residual = projected - q @ (q.T @ projected)
    assert np.linalg.norm(residual) <= 1e-14 * n * np.linalg.norm(projected)


def test_project_out_leaves_its_inputs_alone():
    """The kernel returns a new array; Y and K are unchanged."""
    rng = np.random.default_rng(3)
    y, known = rng.standard_normal((9, 3)), orthonormal(rng, 9, 2)
    y_copy, known_copy = y.copy(), known.copy()
    q = project_out_and_orthonormalise(y, known)
    np.testing.assert_array_equal(y, y_copy)
    np.testing.assert_array_equal(known, known_copy)
    np.testing.assert_allclose(known.T @ q, 0.0, atol=1e-13)


# --- jacobi_svd ---------------------------------------------------------------------------------


@KERNEL_SETTINGS
@given(st.integers(1, 10), st.integers(1, 10), seeds, st.booleans())
def test_jacobi_svd_against_lapack(p, k, seed, graded):
    """Singular values as np.linalg.svd's (zeros where p < k), W orthogonal, and r W with
    orthogonal columns whose norms are s. Graded columns (scales 1 … 1e-16, as R's of a block
    holding null vectors) keep their small singular values to a small relative error."""
    rng = np.random.default_rng(seed)
    scales = 10.0 ** rng.uniform(-16, 0, size=k) if graded else np.ones(k)
    r = rng.standard_normal((p, k)) * scales
    s, w, converged = jacobi_svd(r)
    assert converged
    reference = np.zeros(k)
    values = np.linalg.svd(r, compute_uv=False)
    reference[k - values.size :] = np.sort(values)
    np.testing.assert_allclose(np.sort(s), reference, rtol=0, atol=1e-14 * reference[-1])
    np.testing.assert_allclose(w.T @ w, np.eye(k), rtol=0, atol=1e-13)
    rw = r @ w
    np.testing.assert_allclose(np.linalg.norm(rw, axis=0), s, rtol=0, atol=1e-14 * reference[-1])
    off = rw.T @ rw - np.diag(s**2)
    assert np.abs(off).max() <= 1e-13 * reference[-1] ** 2
    if graded and p >= k:  # R's small singular values, relative to themselves
        square = np.linalg.qr(r)[1]  # triangular, as Rayleigh–Ritz passes it
        s_square = np.sort(jacobi_svd(square)[0])
        tiny = reference > 1e-10 * reference[-1]
        np.testing.assert_allclose(s_square[tiny], reference[tiny], rtol=1e-6)


def test_jacobi_svd_of_exact_cases():
    """A zero matrix, a matrix with a repeated column and a diagonal one."""
    s, w, converged = jacobi_svd(np.zeros((3, 3)))
    assert converged and np.all(s == 0.0) and np.array_equal(w, np.eye(3))
    twin = np.array([[1.0, 1.0], [2.0, 2.0]])
    s, _, _ = jacobi_svd(twin)
    np.testing.assert_allclose(np.sort(s), [0.0, np.sqrt(10.0)], atol=1e-15)
    s, _, _ = jacobi_svd(np.diag([3.0, -1.0, 2.0]))
    np.testing.assert_allclose(s, [3.0, 1.0, 2.0], rtol=1e-15)


# --- count_setup --------------------------------------------------------------------------------


@KERNEL_SETTINGS
@given(st.integers(2, 3), st.integers(3, 25), seeds, st.booleans())
def test_count_setup_against_its_parts(d, n, seed, count_modes):
    """C and Cᵀ as the definition builds them (dense), σ_max a Lanczos estimate never above
    numpy's and equal to it when the steps span the space, and the Gram matrix of the counted
    side (CᵀC or CCᵀ) as numpy's product."""
    rng = np.random.default_rng(seed)
    positions = rng.standard_normal((n, d))
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], dtype=np.int64)
    edges = pairs[rng.choice(len(pairs), size=min(len(pairs), int(rng.integers(1, 3 * n))), replace=False)]
    c = compatibility_dense(positions, edges)
    a = c if count_modes else c.T
    steps = a.shape[1] + 1
    rows, columns, sigma, gram = count_setup(positions, edges, count_modes, np.zeros(1, np.uint64), steps)
    np.testing.assert_array_equal(dense_of(*rows, d * n), c)
    np.testing.assert_array_equal(dense_of(*columns, len(edges)), c.T)
    reference = np.linalg.svd(c, compute_uv=False)[0]
    assert sigma <= reference * (1 + 1e-12)
    assert sigma == pytest.approx(reference, rel=1e-9)
    np.testing.assert_allclose(dense_of(*gram, a.shape[1]), a.T @ a, rtol=0, atol=1e-12 * reference**2)


# --- null_space_rounds -----------------------------------------------------------------------------


def drive_rounds(
    c: np.ndarray, known: np.ndarray, width: int, householder_max: int = 16, max_null: int = 20_000,
    gap_rtol: float = 0.0, polish_steps: int = 0,
):
    """Drive the compiled rounds on dense C with dense solves of CᵀC + δI (numpy): the basis,
    its Ritz values' gap, σ_r's error bound and the requests made."""
    sigma = np.linalg.svd(c, compute_uv=False)[0]
    shift = 1e-13 * sigma**2
    gram = c.T @ c + shift * np.eye(c.shape[1])
    requests = []
    rounds = null_space_rounds(
        *arrays_of(c), np.ascontiguousarray(known), width,
        np.zeros(1, np.uint64), 1e-10 * sigma, shift, 1e-3, 1e4, householder_max, max_null, 2, 60, gap_rtol, polish_steps,
    )
    for request, block, kept, dropped, error in rounds:
        requests.append(request)
        if request == SOLVE:
            block[...] = shift * np.linalg.solve(gram, block)
        elif request == ORTHONORMALISE:
            block[...] = np.linalg.qr(block)[0]
    return block, kept, dropped, error, requests


@pytest.mark.parametrize("householder_max", [16, 0])
@pytest.mark.parametrize("seed", range(6))
def test_null_space_rounds_find_the_null_space(seed, householder_max):
    """A random frame with bars removed, its rigid motions known: the rounds return an
    orthonormal basis of N(C) ⊖ rigid of numpy's dimension (σ < 1e-10 σ_max), inside N(C) to
    round-off, the gap bracketing the threshold; blocks QR'd by the caller (householder_max 0)
    give the same. Every round is announced, the answer comes last."""
    rng = np.random.default_rng(seed)
    d, n = 2 + seed % 2, 12 + 3 * seed
    positions = rng.standard_normal((n, d))
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], dtype=np.int64)
    edges = pairs[rng.choice(len(pairs), size=d * n - 4 - seed, replace=False)]
    c = compatibility_dense(positions, edges)
    rigid = rigid_motion_svd(positions)[0]
    s = np.linalg.svd(c, compute_uv=False)
    expected = d * n - int(np.count_nonzero(s > 1e-10 * s[0])) - rigid.shape[1]
    basis, kept, dropped, error, requests = drive_rounds(c, rigid, 2, householder_max)
    assert basis.shape == (d * n, expected)
    np.testing.assert_allclose(basis.T @ basis, np.eye(expected), atol=1e-12)
    np.testing.assert_allclose(rigid.T @ basis, 0.0, atol=1e-12)
    assert np.linalg.norm(c @ basis) <= 1e-12 * s[0]
    assert dropped <= 1e-10 * s[0] < kept
    assert requests[0] == ROUND and requests[-1] == DONE and requests.count(DONE) == 1
    assert (ORTHONORMALISE in requests) == (householder_max == 0)
    # σ_r's Ritz value: never below σ_r, and some singular value within its error bound
    rank = d * n - rigid.shape[1] - expected
    assert kept >= s[rank - 1] * (1 - 1e-12)
    assert np.min(np.abs(s[:rank] / kept - 1)) <= error


def widening_frames():
    """Frames whose smallest nonzero singular values cluster (the count's Ritz value is then
    furthest from σ_r): a 6 × 6 triangulated patch (2D), a 3 × 3 × 3 cubic patch with face
    diagonals (3D), and a random near-isostatic frame."""
    ij = np.array([(i, j) for j in range(6) for i in range(6)], dtype=float)
    tri = ij @ np.array([[1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    index = {(i, j): 6 * j + i for j in range(6) for i in range(6)}
    bars = [(index[i, j], index[i + a, j + b]) for (i, j) in index for a, b in ((1, 0), (0, 1), (-1, 1))
            if (i + a, j + b) in index]
    yield tri, np.array(bars, dtype=np.int64)
    cube = np.array([(i, j, k) for k in range(3) for j in range(3) for i in range(3)], dtype=float)
    index = {tuple(p.astype(int)): m for m, p in enumerate(cube)}
    steps = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1))
    bars = [(index[p], index[(p[0] + a, p[1] + b, p[2] + c)]) for p in index for a, b, c in steps
            if (p[0] + a, p[1] + b, p[2] + c) in index]
    yield cube, np.array(bars, dtype=np.int64)
    rng = np.random.default_rng(3)
    points = rng.standard_normal((20, 2))
    pairs = np.array([(i, j) for i in range(20) for j in range(i + 1, 20)], dtype=np.int64)
    yield points, pairs[rng.choice(len(pairs), size=37, replace=False)]


@pytest.mark.parametrize("frame", list(widening_frames()), ids=["triangulated", "cubic", "random"])
def test_null_space_rounds_widen_to_sigma_r(frame):
    """Asked for σ_r to 1e-8 the rounds widen its Ritz space with single solves until the bound
    holds, and the value is then numpy's σ_r to that bound; without, the Ritz value stays an
    upper bound, and its bound one on the distance to *some* singular value (on the random frame
    the nearest is not σ_r: 0.1463 against σ_r 0.1318, bound 0.084)."""
    positions, edges = frame
    c = compatibility_dense(positions, edges)
    rigid = rigid_motion_svd(positions)[0]
    s = np.linalg.svd(c, compute_uv=False)
    sigma_r = s[np.count_nonzero(s > 1e-10 * s[0]) - 1]
    _, kept, _, error, requests = drive_rounds(c, rigid, 2, gap_rtol=1e-8, polish_steps=60)
    assert error <= 1e-8 and abs(kept / sigma_r - 1) <= error
    _, rough, _, rough_error, rough_requests = drive_rounds(c, rigid, 2)
    assert rough >= sigma_r * (1 - 1e-12)
    assert np.min(np.abs(s[s > 1e-10 * s[0]] / rough - 1)) <= rough_error
    assert requests.count(SOLVE) > rough_requests.count(SOLVE)


@KERNEL_SETTINGS
@given(st.integers(2, 12), st.integers(1, 5), seeds)
def test_ritz_space_widened_against_numpy(n_rows_extra, k, seed):
    """ritz_space and extend_ritz_space keep A·Q W = Q_A B with Q_A, Q orthonormal, W
    orthogonal and B's columns orthogonal; the new column is x ⟂ (null, Q) normalised; the
    smallest Ritz pair is numpy's smallest singular value of A·Q' with its right vector, and
    its residual ‖AᵀA u − θ²u‖ numpy's."""
    rng = np.random.default_rng(seed)
    n = k + 4
    a = rng.standard_normal((n + n_rows_extra, n))
    null = np.linalg.qr(rng.standard_normal((n, 2)))[0]
    q = np.linalg.qr(rng.standard_normal((n, k)) - null @ (null.T @ rng.standard_normal((n, k))))[0]
    q = np.ascontiguousarray(q - null @ (null.T @ q))
    q = np.ascontiguousarray(np.linalg.qr(q)[0])
    csr = arrays_of(a)
    qa, b, w = ritz_space(*csr, q)
    x = rng.standard_normal(n)
    q2, qa2, b2, w2, grew = extend_ritz_space(*csr, np.ascontiguousarray(null), q, qa, b, w, x)
    assert grew and q2.shape == (n, k + 1)
    np.testing.assert_allclose(q2.T @ q2, np.eye(k + 1), atol=1e-12)
    np.testing.assert_allclose(null.T @ q2, 0.0, atol=1e-12)
    np.testing.assert_allclose(qa2.T @ qa2, np.eye(k + 1), atol=1e-12)
    np.testing.assert_allclose(w2.T @ w2, np.eye(k + 1), atol=1e-12)
    np.testing.assert_allclose(a @ q2 @ w2, qa2 @ b2, atol=1e-12 * np.linalg.norm(a))
    gram = b2.T @ b2
    np.testing.assert_allclose(gram - np.diag(np.diag(gram)), 0.0, atol=1e-12 * np.linalg.norm(a) ** 2)
    theta, u, residual = smallest_ritz_pair(*csr, q2, b2, w2)
    _, sv, vt = np.linalg.svd(a @ q2)
    assert theta == pytest.approx(sv[-1], rel=1e-10)
    assert abs(u @ (q2 @ vt[-1])) == pytest.approx(1.0, abs=1e-8)
    assert residual == pytest.approx(np.linalg.norm(a.T @ (a @ u) - theta**2 * u), rel=1e-6, abs=1e-12)
    # a vector already in span(null, Q) leaves the space as it is
    *_, grew = extend_ritz_space(*csr, np.ascontiguousarray(null), q, qa, b, w, q @ rng.standard_normal(k))
    assert not grew


def test_relative_error_bound():
    """1 − √(1 − ρ/θ²): the largest relative distance from θ of √λ for |λ − θ²| ≤ ρ; 1 once ρ ≥ θ²."""
    assert relative_error_bound(2.0, 0.0) == 0.0
    assert relative_error_bound(2.0, 4.0) == 1.0 and relative_error_bound(0.0, 1e-30) == 1.0
    theta, rho = 3.0, 0.9
    bound = relative_error_bound(theta, rho)
    assert bound == pytest.approx(1 - np.sqrt(theta**2 - rho) / theta, rel=1e-14)
    assert np.sqrt(theta**2 + rho) / theta - 1 <= bound


def test_null_space_rounds_refuse_past_max_null():
    """Forty free nodes (no bars) have 80 − 3 nontrivial zero modes: with room for 10 the rounds
    ask the caller to refuse and stop there."""
    rng = np.random.default_rng(1)
    positions = rng.standard_normal((40, 2))
    c = compatibility_dense(positions, np.array([[0, 1]], dtype=np.int64))
    *_, requests = drive_rounds(c, rigid_motion_svd(positions)[0], 2, max_null=10)
    assert requests[-1] == TOO_MANY and DONE not in requests


# --- the random stream, the normalisation, the cache ---------------------------------------------


def splitmix64(state: int, count: int) -> list[int]:
    """The next ``count`` outputs of SplitMix64 from ``state``, in Python integers (Steele, Lea &
    Flood 2014; Vigna's reference C code)."""
    out, mask = [], 2**64 - 1
    for _ in range(count):
        state = (state + 0x9E3779B97F4A7C15) & mask
        z = ((state ^ (state >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        out.append(z ^ (z >> 31))
    return out


def test_splitmix64_reference_starts_with_its_published_output():
    assert splitmix64(0, 1) == [0xE220A8397B1DCDAF]


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**64 - 1), st.integers(1, 7), st.integers(1, 5))
def test_uniform_block_is_the_splitmix64_sequence_in_order(seed, rows, cols):
    """Row-major outputs b·2⁻⁵² − 1 (b the top 53 bits) in [−1, 1); the state advances in place,
    so two draws give the same numbers as one draw of both."""
    state = np.array([seed], dtype=np.uint64)
    first = uniform_block(state, rows, cols)
    second = uniform_block(state, 1, 2)
    outputs = splitmix64(seed, rows * cols + 2)
    expected = np.array([(z >> 11) * 2.0**-52 - 1.0 for z in outputs])
    np.testing.assert_array_equal(np.concatenate([first.ravel(), second.ravel()]), expected)
    assert np.all((-1.0 <= expected) & (expected < 1.0))
    assert int(state[0]) == (seed + (rows * cols + 2) * 0x9E3779B97F4A7C15) % 2**64


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 30),
    st.integers(1, 3),
    st.integers(-300, 300),
    seeds,
)
def test_normalised_centres_and_scales_like_numpy(n, d, exponent, seed):
    """Centroid 0 and RMS radius 1 (a single point goes to the origin), computed without overflow
    at any scale: numpy's mean and RMS of the same points, in units of max |x|."""
    x = np.random.default_rng(seed).uniform(-1.0, 1.0, (n, d)) * 10.0**exponent
    got = normalised(x)
    y = x / np.max(np.abs(x))
    y = y - y.mean(axis=0)
    radius = np.sqrt(np.mean(np.sum(y**2, axis=1)))
    np.testing.assert_allclose(got, y / radius if radius > 0 else y, rtol=1e-12, atol=1e-12)
    frozen = x.copy()
    frozen.flags.writeable = False
    np.testing.assert_array_equal(normalised(frozen), got)
    np.testing.assert_array_equal(normalised(x[:1]), np.zeros((1, d)))


NOWHERE = """
from numba.core.caching import _CacheLocator


class Nowhere(_CacheLocator):
    @classmethod
    def from_function(cls, py_func, py_file):
        return None  # as on a read-only install run by a user without a home
"""


def test_kernels_compile_where_no_cache_directory_is_writable(tmp_path):
    """numba refuses ``cache=True`` when it finds no writable cache directory (a RuntimeError at
    import); the kernels then compile in the process instead, and the count still works."""
    (tmp_path / "nowhere.py").write_text(NOWHERE)
    script = (
        "from zeromode.solver import Frame, analyze\n"
        "from zeromode.solver.analysis.sparse_kernels import times\n"
        "square = Frame.build([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1], [1, 2], [2, 3], [3, 0]])\n"
        "a = analyze(square, method='sparse')\n"
        "print(type(times._cache).__name__, a.rank, a.nontrivial_zero_modes)\n"
    )
    env = {
        **os.environ,
        "PYTHONPATH": str(tmp_path),
        "NUMBA_CACHE_LOCATOR_CLASSES": "nowhere.Nowhere",
    }
    env.pop("NUMBA_CACHE_DIR", None)
    out = subprocess.run(
        [sys.executable, "-c", script],
        check=False,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["NullCache", "4", "1"]
