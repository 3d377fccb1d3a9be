"""Allosteric design (paper, "Combining Network Modes for Potential Applications": long-range
coupled conformational regulation), checked from scratch.

The claim: drive the source nodes with u_src and let the frame do what its bars allow, i.e.
take the zero mode u ∈ N(C) whose source rows equal u_src (oracles.rigidity.driven_response: C
from its definition, N(C) from numpy's SVD, least squares for the coefficients). That response
is unique and its target rows equal the prescribed u_tgt to 1e-9 relative, at any distance.
The frame itself is checked with the same C and PyRigi (one nontrivial mode, no self-stress).

The reported robustness figures are recomputed here: the gap from the SVD of the unit
compatibility matrix, the sensitivity by re-solving the response of perturbed frames (finite
differences over every coordinate, then the worst direction moved for real).
"""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient
from oracles.designs import check_frame_modes
from oracles.rigidity import (
    compatibility_matrix,
    driven_response,
    kernel,
    normalised,
    rigid_generators,
    span,
)

from zeromode.service.rest.app import create_app
from zeromode.solver.applications.allostery import (
    MAX_MODULES,
    design_allosteric,
    source_base,
)
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.tolerances import GAP_FLOOR, TARGET_ERROR_MAX


def sites(d: int, distance: float, seed: int = 0):
    """Source and target sites of d + 1 nodes each with random motions; the same shapes for every
    distance: the target is the seeded cloud moved ``distance`` along x (site radii ≈ 1.2)."""
    rng = np.random.default_rng([d, seed])
    x_src, x_tgt = rng.standard_normal((d + 1, d)), rng.standard_normal((d + 1, d))
    u_src, u_tgt = rng.standard_normal((d + 1, d)), rng.standard_normal((d + 1, d))
    x_tgt[:, 0] += distance
    return x_src, u_src, x_tgt, u_tgt


def site_size(x_src, x_tgt) -> float:
    """The larger RMS radius of the two sites: the unit of distances and perturbations."""
    return max(float(np.sqrt(np.mean(np.sum((x - x.mean(0)) ** 2, axis=1)))) for x in (x_src, x_tgt))


CASES = [(2, 0.0), (2, 3.0), (2, 12.0), (2, 48.0), (2, 200.0), (3, 0.0), (3, 3.0), (3, 24.0), (3, 96.0)]


@pytest.mark.parametrize(("d", "distance"), CASES)
def test_driving_the_source_moves_the_target_as_prescribed(d, distance):
    x_src, u_src, x_tgt, u_tgt = sites(d, distance)
    result = design_allosteric(x_src, u_src, x_tgt, u_tgt, seed=0)
    frame, modes = result.design.frame, result.design.modes
    x, edges = np.asarray(frame.positions), np.asarray(frame.edges)
    k_src, k_tgt = len(x_src), len(x_tgt)
    source, target = np.arange(k_src), np.arange(k_src, k_src + k_tgt)
    assert result.source == tuple(source) and result.target == tuple(target)
    assert np.array_equal(x[source], x_src) and np.array_equal(x[target], x_tgt)
    assert np.array_equal(modes[0][source], u_src) and np.array_equal(modes[0][target], u_tgt)
    assert set(result.relays) <= set(range(k_src + k_tgt, len(x)))
    check_frame_modes(x, edges, modes, use_pyrigi=len(x) <= 30)

    response = driven_response(x, edges, source, u_src)
    error = np.linalg.norm(response[target] - u_tgt) / np.linalg.norm(u_tgt)
    assert error <= TARGET_ERROR_MAX
    # The report agrees with the response computed here and meets its floors.
    assert np.allclose(
        result.achieved_target_motion, response[target], rtol=0, atol=1e-9 * np.linalg.norm(u_tgt)
    )
    assert result.figures.target_error <= TARGET_ERROR_MAX
    assert result.figures.gap >= GAP_FLOOR
    assert abs(result.distance - np.linalg.norm(x_tgt.mean(0) - x_src.mean(0))) <= 1e-12 * max(distance, 1)
    print(
        f"\nd={d} distance={distance}: N={len(x)}, N_B={len(edges)}, modules {result.modules}, "
        f"error {error:.1e}, gap {result.figures.gap:.1e}, sensitivity {result.figures.sensitivity:.1e}"
    )


@pytest.mark.parametrize(("d", "distance"), [(2, 24.0), (3, 24.0)])
def test_gap_is_the_smallest_nonzero_singular_value_of_the_unit_compatibility_matrix(d, distance):
    result = design_allosteric(*sites(d, distance))
    x, edges = normalised(result.design.frame.positions), np.asarray(result.design.frame.edges)
    c = compatibility_matrix(x, edges)
    unit = c / np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)[:, None]
    s = np.linalg.svd(unit, compute_uv=False)
    zero_modes = d * (d + 1) // 2 + 1
    nonzero = s[: x.size - zero_modes]  # no self-stress: N_B ≥ dN − zero modes singular values
    assert s.size == len(edges) == x.size - zero_modes
    assert result.figures.gap == pytest.approx(nonzero[-1] / nonzero[0], rel=1e-6)


def perturbed_response(x, edges, source, target, u_src) -> np.ndarray:
    """Target rows of the response of the frame at positions x (numpy SVD null space; the source
    rows matched in least squares: a perturbed frame may not realise u_src exactly)."""
    n, d = x.shape
    null = kernel(compatibility_matrix(normalised(x), edges))
    rows = (source[:, None] * d + np.arange(d)).ravel()
    coef, *_ = np.linalg.lstsq(null[rows], u_src.ravel(), rcond=None)
    return (null @ coef).reshape(n, d)[target].ravel()


@pytest.mark.parametrize(("d", "distance"), [(2, 12.0), (3, 3.0)])
def test_sensitivity_is_the_response_change_of_perturbed_frames(d, distance):
    """Finite differences of the re-solved response over every coordinate give J; the reported
    sensitivities are ‖ΠJ‖ s/‖Πu_T‖ and ‖J‖ s/‖u_T‖ times the stated perturbation (Π: off the
    target site's rigid motions, s: the site size). Moving the nodes for real along J's worst
    direction by that perturbation changes the target's shape change by the reported amount."""
    x_src, u_src, x_tgt, u_tgt = sites(d, distance)
    result = design_allosteric(x_src, u_src, x_tgt, u_tgt)
    f = result.figures
    x, edges = np.asarray(result.design.frame.positions), np.asarray(result.design.frame.edges)
    source, target = np.asarray(result.source), np.asarray(result.target)
    s = site_size(x_src, x_tgt)
    h = 1e-6 * s
    jac = np.zeros((len(target) * d, x.size))
    for i in range(x.size):
        step = np.zeros(x.size)
        step[i] = h
        plus = perturbed_response(x + step.reshape(x.shape), edges, source, target, u_src)
        minus = perturbed_response(x - step.reshape(x.shape), edges, source, target, u_src)
        jac[:, i] = (plus - minus) / (2 * h)
    rigid = span(rigid_generators(x_tgt))
    off = np.eye(len(target) * d) - rigid @ rigid.T
    u_t = u_tgt.ravel()
    shape = np.linalg.norm(off @ jac, 2) * s / np.linalg.norm(off @ u_t) * f.perturbation
    motion = np.linalg.norm(jac, 2) * s / np.linalg.norm(u_t) * f.perturbation
    assert f.sensitivity == pytest.approx(shape, rel=1e-3)
    assert f.motion_sensitivity == pytest.approx(motion, rel=1e-3)
    worst = np.linalg.svd(off @ jac)[2][0]
    moved = perturbed_response(x + f.perturbation * s * worst.reshape(x.shape), edges, source, target, u_src)
    change = np.linalg.norm(off @ (moved - u_t)) / np.linalg.norm(off @ u_t)
    assert change == pytest.approx(f.sensitivity, rel=1e-2)


@pytest.mark.parametrize("d", [2, 3])
def test_sensitivity_and_gap_do_not_degrade_with_distance(d):
    """The same sites at 24, 96 and 200 site sizes, economy chains: relays grow geometrically, so the target's
    sensitivity stays within a factor 2, and the gap stays 100× above its floor and within a
    factor 30. Which modules the 3D placement picks follows round-off, which differs between
    BLAS kernels: its gaps span 3.6× with OpenBLAS's AVX2 kernels (1.1e-3 … 3.8e-3) and 16× with
    its AVX-512 ones (2.8e-4 … 4.4e-3); 2D ones agree (3.8e-2 … 5.9e-2 with either)."""
    figures = [design_allosteric(*sites(d, distance), robustness="economy").figures for distance in (24.0, 96.0, 200.0)]
    sensitivity = [f.sensitivity for f in figures]
    gaps = [f.gap for f in figures]
    assert max(sensitivity) <= 2 * min(sensitivity)
    assert min(gaps) >= 100 * GAP_FLOOR and max(gaps) <= 30 * min(gaps)
    assert all(f.target_error <= TARGET_ERROR_MAX for f in figures)


# The builder's error model of ResponseFigures.amplification: every node moved by EPSILON mean
# bar lengths in a seeded uniformly random direction (small enough for the linear order, large
# enough above the SVD's round-off: response changes of ~1e-6 against ~1e-13).
EPSILON = 1e-7


def svd_response(x, edges, source, target, u_src) -> np.ndarray:
    """Target rows (k_tgt, d) of the zero mode of the frame at x whose source rows match u_src in
    least squares; the null space from numpy's SVD of C (rank at 1e-9 of σ_max, C built from its
    definition on positions centred and scaled to unit RMS radius)."""
    n, d = x.shape
    y = x - x.mean(axis=0)
    y = y / np.sqrt(np.mean(np.sum(y**2, axis=1)))
    _, s, vt = np.linalg.svd(compatibility_matrix(y, edges), full_matrices=True)
    null = vt[int(np.count_nonzero(s > 1e-9 * s[0])) :].T
    rows = (np.asarray(source)[:, None] * d + np.arange(d)).ravel()
    coef, *_ = np.linalg.lstsq(null[rows], np.ravel(u_src), rcond=None)
    return (null @ coef).reshape(n, d)[np.asarray(target)]


def sampled_amplifications(result, u_src, seeds: int) -> np.ndarray:
    """‖δw_T‖/(ε‖w_T‖) of ``seeds`` seeded perturbations: each node moved by ε·ℓ̄ (ℓ̄ the mean bar
    length) along a random unit vector (a normalised Gaussian: uniform on the sphere)."""
    x, edges = np.asarray(result.design.frame.positions), np.asarray(result.design.frame.edges)
    mean_bar = np.mean(np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1))
    w = svd_response(x, edges, result.source, result.target, u_src)
    out = []
    for seed in range(seeds):
        e = np.random.default_rng(seed).standard_normal(x.shape)
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        moved = svd_response(x + EPSILON * mean_bar * e, edges, result.source, result.target, u_src)
        out.append(np.linalg.norm(moved - w) / np.linalg.norm(w) / EPSILON)
    return np.array(out)


def amplification_within_its_report_and_the_floor(result, u_src, distance: float) -> tuple[np.ndarray, float]:
    """Eight seeded fabrication errors re-solved by numpy's SVD (sampled_amplifications): none
    above the reported A_worst, their RMS within a factor 3 of the reported A, and the worst of
    the first four under the issue's floor 100·√(D/12); (the samples, their RMS)."""
    f = result.figures
    sampled = sampled_amplifications(result, u_src, 8)
    assert sampled.max() <= f.amplification_worst * 1.01
    rms = float(np.sqrt(np.mean(sampled**2)))
    assert f.amplification / 3 <= rms <= 3 * f.amplification
    assert sampled[:4].max() <= 100 * np.sqrt(distance / 12)
    return sampled, rms


@pytest.mark.parametrize(("d", "distance"), [(2, 12.0), (2, 48.0), (3, 12.0), (3, 48.0)])
def test_amplification_is_what_seeded_fabrication_errors_do(d, distance):
    """Perturbed frames re-solved by numpy's SVD: no sample exceeds the reported worst-direction
    amplification (every sample has RMS node error ε·ℓ̄, to first order); the RMS of 8 samples is
    the reported amplification within a factor 3 (its expectation is A², the mean of 8 squares of
    a ≤ k_tgt·d-dimensional Gaussian form has relative spread ≤ 0.5); and the issue's floor,
    A ≤ 100·√(D/12) for the worst of four seeded perturbations, holds with the default options
    for these sites."""
    x_src, u_src, x_tgt, u_tgt = sites(d, distance)
    result = design_allosteric(x_src, u_src, x_tgt, u_tgt)
    f = result.figures
    sampled, rms = amplification_within_its_report_and_the_floor(result, u_src, distance)
    print(f"\nd={d} D={distance}: A reported {f.amplification:.0f} (worst {f.amplification_worst:.0f}), sampled "
          f"RMS {rms:.0f}, worst of four {sampled[:4].max():.0f}")


@pytest.mark.parametrize(("distance", "site_seed"), [(12.0, 1), (12.0, 2), (48.0, 1), (48.0, 2)])
def test_3d_amplification_of_the_default_design_is_what_seeded_errors_do(distance, site_seed):
    """3D, the benchmark's other site shapes (1 missed the floor at D = 12 before the source-side
    search: sampled 106 > 100; 2 is the hardest shape, 679 at D = 48 before the source base):
    the default design stays exact (the response driven through numpy's SVD of C hits u_tgt to
    1e-9, one nontrivial mode, no self-stress), eight seeded fabrication errors re-solved from
    scratch agree with the reported A (RMS within a factor 3, none above A_worst), and the worst
    of four meets the issue's floor 100·√(D/12) (D = 48: sampled 69 and 164 in the benchmark;
    D = 200 there too, docs/benchmarks/allostery.md, but a design of ~120 nodes takes ~6 s)."""
    x_src, u_src, x_tgt, u_tgt = sites(3, distance, site_seed)
    result = design_allosteric(x_src, u_src, x_tgt, u_tgt)
    x, edges = np.asarray(result.design.frame.positions), np.asarray(result.design.frame.edges)
    check_frame_modes(x, edges, result.design.modes, use_pyrigi=len(x) <= 30)
    response = driven_response(x, edges, result.source, u_src)[list(result.target)]
    assert np.linalg.norm(response - u_tgt) <= TARGET_ERROR_MAX * np.linalg.norm(u_tgt)
    f = result.figures
    sampled, rms = amplification_within_its_report_and_the_floor(result, u_src, distance)
    print(f"\n3D D={distance} shape {site_seed}: A reported {f.amplification:.0f}, sampled RMS {rms:.0f}, "
          f"worst of four {sampled[:4].max():.0f}, floor {100 * np.sqrt(distance / 12):.0f}")


@pytest.mark.parametrize("d", [2, 3])
def test_a_source_base_keeps_its_bars_and_moves_like_the_site_at_any_reach(d):
    """source_base from the bar constraint: every base node sits ``reach`` from the site's centroid,
    on the target's side (e_1 ≥ 0), joined to d site nodes whose bars keep their lengths under
    the site's motion ((u_a − u_p)·(x_a − x_p) = 0, checked here); and its motion stays of the
    site's size (≤ 5 max|u_site|) whether the base is 40 or 400 site sizes away — the direction
    is what keeps it bounded: the same bars from a node 400 away in a seeded random direction
    need a motion hundreds of times larger (solved here by numpy), the lever the base avoids."""
    x_src, u_src, _, _ = sites(d, 48.0, 2)
    centre, scale = x_src.mean(axis=0), float(np.abs(u_src).max())
    for reach in (40.0, 400.0):
        positions, motions, anchors, rest = source_base(x_src, u_src, reach)
        assert len(positions) == d + 1 and len(rest) == 0
        assert np.allclose(np.linalg.norm(positions - centre, axis=1), reach)
        assert np.all(positions[:, 0] >= centre[0])
        for x_p, u_p, subset in zip(positions, motions, anchors):
            assert len(set(subset)) == d
            bars = x_src[subset] - x_p
            assert np.abs(np.einsum("ad,ad->a", u_src[subset] - u_p, bars)).max() <= 1e-9 * scale * reach
            assert np.linalg.norm(u_p) <= 5 * scale
    direction = np.random.default_rng(0).standard_normal(d)
    x_far = centre + 400.0 * direction / np.linalg.norm(direction)
    bars = x_src[anchors[0]] - x_far
    u_far = np.linalg.solve(bars, np.einsum("ad,ad->a", u_src[anchors[0]], bars))
    assert np.linalg.norm(u_far) >= 20 * max(np.linalg.norm(motions, axis=1))


def test_economy_trades_amplification_for_nodes():
    """robustness="economy" returns the first chain that meets the floors (the default chain); the
    default robust search includes that chain, so its amplification is never larger, and both
    answers state it (checked against sampled perturbations as above)."""
    x_src, u_src, x_tgt, u_tgt = sites(2, 48.0)
    robust = design_allosteric(x_src, u_src, x_tgt, u_tgt)
    economy = design_allosteric(x_src, u_src, x_tgt, u_tgt, robustness="economy")
    assert robust.figures.amplification <= economy.figures.amplification
    for result in (robust, economy):
        rms = float(np.sqrt(np.mean(sampled_amplifications(result, u_src, 8) ** 2)))
        assert result.figures.amplification / 3 <= rms <= 3 * result.figures.amplification
    with pytest.raises(InvalidInput):
        design_allosteric(x_src, u_src, x_tgt, u_tgt, robustness="cheap")


def random_rotation(d: int, seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((d, d)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else q[:, ::-1] if d == 2 else -q


@pytest.mark.parametrize(("d", "distance"), [(2, 3.0), (2, 48.0), (3, 24.0)])
@pytest.mark.parametrize(
    ("scale", "speed", "shift", "rotate"),
    [
        (100.0, 1.0, 0.0, False), (1e-3, 1e-3, 0.0, False), (1.0, 1.0, 37.0, False), (1.0, 2.0, 0.0, True),
        (1e3, 5.0, -4.0, True), (1e6, 1e-6, 3e6, True), (1e-6, 1e6, -2e-6, True),
    ],
)
def test_design_is_the_same_up_to_the_same_similarity(d, distance, scale, speed, shift, rotate):
    """x ↦ λQx + t and u ↦ μQu on the request give the same bars and x ↦ λQx + t, u ↦ μQu on the
    frame and its mode."""
    x_src, u_src, x_tgt, u_tgt = sites(d, distance)
    q = random_rotation(d, 7) if rotate else np.eye(d)
    reference = design_allosteric(x_src, u_src, x_tgt, u_tgt)
    moved = design_allosteric(
        scale * x_src @ q.T + shift, speed * u_src @ q.T, scale * x_tgt @ q.T + shift, speed * u_tgt @ q.T
    )
    a, b = reference.design, moved.design
    assert np.array_equal(a.frame.edges, b.frame.edges)
    expected_x = scale * a.frame.positions @ q.T + shift
    expected_u = speed * a.modes[0] @ q.T
    assert np.abs(b.frame.positions - expected_x).max() <= 1e-9 * np.abs(expected_x).max()
    assert np.abs(b.modes[0] - expected_u).max() <= 1e-9 * np.abs(expected_u).max()
    assert b.frame.n_nodes == a.frame.n_nodes and moved.relays == reference.relays


def test_linear_response_scales_with_the_drive():
    """Linear order: driving with 2·u_src moves the target by 2·u_tgt; −u_src by −u_tgt."""
    x_src, u_src, x_tgt, u_tgt = sites(2, 24.0, 1)
    result = design_allosteric(x_src, u_src, x_tgt, u_tgt, seed=0)
    frame = result.design.frame
    target = list(result.target)
    for factor in (2.0, -1.0):
        response = driven_response(frame.positions, frame.edges, list(result.source), factor * u_src)
        assert np.allclose(response[target], factor * u_tgt, atol=1e-9 * np.linalg.norm(u_tgt))


def rotation_field(x: np.ndarray) -> np.ndarray:
    """An infinitesimal rotation about the first axis pair plus a translation: rigid."""
    u = np.zeros_like(x)
    u[:, 0], u[:, 1] = -x[:, 1], x[:, 0]
    return u + 0.3


def refusals(d: int = 2):
    """(code, arguments, keywords) of every request the designer refuses."""
    x_src, u_src, x_tgt, u_tgt = sites(d, 12.0, 2)
    overlapping = x_tgt.copy()
    overlapping[1] = x_src[2]
    twin = x_src.copy()
    twin[1] = twin[0]
    return [
        ("overlapping_sites", (x_src, u_src, overlapping, u_tgt), {}),
        ("degenerate_specified", (twin, u_src, x_tgt, u_tgt), {}),
        ("rigid_source", (x_src, np.zeros_like(u_src), x_tgt, u_tgt), {}),
        ("rigid_source", (x_src, np.ones_like(u_src), x_tgt, u_tgt), {}),
        ("rigid_source", (x_src, rotation_field(x_src), x_tgt, u_tgt), {}),
        ("rigid_target", (x_src, u_src, x_tgt, np.zeros_like(u_tgt)), {}),
        ("rigid_target", (x_src, u_src, x_tgt, 1e-3 * rotation_field(x_tgt)), {}),
        ("invalid_shape", (x_src, u_src[:-1], x_tgt, u_tgt), {}),
        ("invalid_options", (x_src, u_src, x_tgt, u_tgt), {"relay_growth": 0.5}),
        ("invalid_options", (x_src, u_src, x_tgt, u_tgt), {"relay_spacing": 0.0}),
        ("too_expensive", (x_src, u_src, x_tgt, u_tgt), {"relay_spacing": 1e-3, "relay_growth": 1.0}),
    ]


@pytest.mark.parametrize("d", [2, 3])
def test_bad_requests_are_refused_by_the_solver(d):
    for code, args, kwargs in refusals(d):
        with pytest.raises(DomainError) as err:
            design_allosteric(*args, **kwargs)
        assert err.value.code == code, (code, err.value.message)
        assert len(err.value.message) > 20
        if code == "too_expensive":
            assert str(MAX_MODULES) in err.value.message  # the limit is named
        if code.startswith("invalid"):
            assert isinstance(err.value, InvalidInput)


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(), raise_server_exceptions=False)


def request_body(x_src, u_src, x_tgt, u_tgt, **options) -> dict:
    return {
        "dim": len(x_src[0]),
        "source": {"positions": np.asarray(x_src).tolist(), "motion": np.asarray(u_src).tolist()},
        "target": {"positions": np.asarray(x_tgt).tolist(), "motion": np.asarray(u_tgt).tolist()},
        "options": options,
    }


def test_bad_requests_answer_422_with_their_code(client):
    for code, args, kwargs in refusals():
        response = client.post("/v1/design/allosteric", json=request_body(*args, **kwargs))
        assert response.status_code == 422, (code, response.text)
        detail = response.json()["detail"]
        if code == "invalid_options":  # relay_growth < 1 and relay_spacing ≤ 0 fail the schema
            assert detail["code"] == "invalid_request"
        else:
            assert detail["code"] == code and len(detail["message"]) > 20


def test_an_answer_missing_the_floors_is_422_with_the_best_figures(client):
    """Relays of about 5e-4 site sizes growing by 1.2 next to a site of size 1 sit where the
    construction verifies but its target error, some 1e-8 – 1e-10, is set by round-off
    (sensitivity ≈ 2e-2): which spacings miss the 1e-9 floor depends on the BLAS kernels
    (OpenBLAS's AVX2 and AVX-512 ones disagree on 3 of these 5). Every answer keeps its word:
    a 200 meets the floors, and the others are 422 inaccurate_design whose best figures are
    those of a frame that misses a floor (4 of the 5 on either kernel)."""
    x_src, u_src, x_tgt, u_tgt = sites(2, 48.0)
    missed = []
    for spacing in (4.6e-4, 4.8e-4, 5.0e-4, 5.2e-4, 5.4e-4):
        body = request_body(x_src, u_src, x_tgt, u_tgt, relay_spacing=spacing, relay_growth=1.2)
        response = client.post("/v1/design/allosteric", json=body)
        if response.status_code == 200:
            report = response.json()["report"]
            assert report["target_error"] <= TARGET_ERROR_MAX and report["gap"] >= GAP_FLOOR
            continue
        assert response.status_code == 422, response.text[:300]
        missed.append((spacing, response.json()["detail"]))
    assert missed
    for spacing, detail in missed:
        assert detail["code"] == "inaccurate_design"
        best = detail["best"]
        assert best["target_error"] > TARGET_ERROR_MAX or best["gap"] < GAP_FLOOR
        assert best["chain"]["relay_spacing"] == pytest.approx(spacing)
        assert f"{best['gap']:.2e}" in detail["message"]


def test_robustness_is_an_option_and_every_answer_states_its_amplification(client):
    """The REST answer carries the solver's amplification for either choice; an unknown choice is a
    422 naming the field."""
    x_src, u_src, x_tgt, u_tgt = sites(2, 48.0)
    for robustness in ("robust", "economy"):
        response = client.post(
            "/v1/design/allosteric", json=request_body(x_src, u_src, x_tgt, u_tgt, robustness=robustness)
        )
        assert response.status_code == 200, response.text[:300]
        report = response.json()["report"]
        expected = design_allosteric(x_src, u_src, x_tgt, u_tgt, robustness=robustness).figures
        assert report["amplification"] == pytest.approx(expected.amplification, rel=1e-9)
        assert report["amplification_worst"] == pytest.approx(expected.amplification_worst, rel=1e-9)
    response = client.post("/v1/design/allosteric", json=request_body(x_src, u_src, x_tgt, u_tgt, robustness="cheap"))
    assert response.status_code == 422 and "robustness" in response.text


def test_relays_too_small_to_verify_are_422_without_figures(client):
    """Relays of 1e-5 site sizes: every chain has zero modes beyond the designed ones at the
    rank's relative threshold, so none verifies and there are no figures to report."""
    x_src, u_src, x_tgt, u_tgt = sites(2, 48.0)
    response = client.post(
        "/v1/design/allosteric", json=request_body(x_src, u_src, x_tgt, u_tgt, relay_spacing=1e-5)
    )
    assert response.status_code == 422, response.text[:300]
    detail = response.json()["detail"]
    assert (detail["code"], detail["best"]) == ("inaccurate_design", None)
    assert "did not verify" in detail["message"] and "zero modes instead of" in detail["message"]


def test_the_report_carries_the_figures(client):
    x_src, u_src, x_tgt, u_tgt = sites(3, 48.0)
    response = client.post("/v1/design/allosteric", json=request_body(x_src, u_src, x_tgt, u_tgt))
    assert response.status_code == 200, response.text[:300]
    report = response.json()["report"]
    assert report["target_error"] <= TARGET_ERROR_MAX and report["gap"] >= GAP_FLOOR
    assert 0 < report["sensitivity"] <= report["motion_sensitivity"] * 10
    assert 0 < report["amplification"] <= report["amplification_worst"]
    assert report["perturbation"] == 1e-6 and report["modules"] > 1
    chain = report["chain"]
    again = client.post(
        "/v1/design/allosteric",
        json=request_body(
            x_src, u_src, x_tgt, u_tgt, relay_spacing=chain["relay_spacing"], relay_growth=chain["relay_growth"],
            seed=chain["seed"],
        ),
    )
    a, b = again.json()["frame"], response.json()["frame"]  # the chain reported reproduces it
    assert a["edges"] == b["edges"]
    assert np.allclose(a["positions"], b["positions"], rtol=1e-12, atol=1e-12 * np.abs(b["positions"]).max())
