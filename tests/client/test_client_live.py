"""The client against the real service (uvicorn on loopback): health, analyze, errors, async.

Counts are checked against the paper's examples and Maxwell counting; modes and stresses
against a compatibility matrix and rigid motions built from scratch (tests/oracles).
"""

from __future__ import annotations

import asyncio
from importlib.metadata import version

import numpy as np
import pytest
from oracles import frames
from oracles.motion import boundary_strains, relative_bar_error
from oracles.rigidity import (
    compatibility_matrix,
    driven_response,
    normalised,
    reference_counts,
    rigid_generators,
)

from zeromode_client import Analysis, AsyncClient, Client, Frame, ZeromodeError

TRIANGLE = Frame.from_json(frames.TRIANGLE)
SQUARE = Frame.from_json(frames.SQUARE)
K4_PLANE = Frame.from_json(frames.K4_SQUARE)
K4_SPACE = Frame.from_json(frames.TETRAHEDRON)


@pytest.fixture
def client(service_url: str):
    with Client(service_url, timeout=30.0) as c:
        yield c


def test_health_reports_the_installed_version(client: Client) -> None:
    health = client.health()
    assert health.status == "ok"
    assert health.version == version("zeromode")


def test_triangle_is_rigid(client: Client) -> None:
    """Paper Fig. 1d: d=2, N=3, N_B=3 → 3 zero modes, all rigid."""
    a = client.analyze(TRIANGLE)
    counts = (a.nodes, a.edges, a.dim, a.maxwell_count, a.rank, a.zero_modes)
    assert counts == (3, 3, 2, 3, 3, 3)
    assert (a.rigid_body_modes, a.nontrivial_zero_modes, a.self_stresses) == (3, 0, 0)
    assert a.modes.shape == (0, 3, 2) and a.stresses.shape == (0, 3)
    assert a.rank_gap.last_nonzero > 0 and a.rank_gap.first_zero == 0


def test_planar_k4_has_one_self_stress(client: Client) -> None:
    a = client.analyze(K4_PLANE)
    assert (a.rank, a.zero_modes, a.nontrivial_zero_modes, a.self_stresses) == (5, 3, 0, 1)
    assert a.modes.shape == (0, 4, 2) and a.stresses.shape == (1, 6)
    c = compatibility_matrix(K4_PLANE.positions, K4_PLANE.edges)
    stress = a.stresses[0]
    assert np.linalg.norm(c.T @ stress) < 1e-9  # equilibrium: Cᵀs = 0
    assert np.linalg.norm(stress) == pytest.approx(1.0)
    assert np.all(np.abs(stress) > 0.1)  # every bar of K4 carries the stress


def test_sigma_r_to_a_requested_bound(client: Client) -> None:
    """gap_rtol reaches the service: the square with a diagonal by the sparse route, σ_r as
    numpy's SVD of the normalised C gives it, within the bound the answer states."""
    braced = Frame.from_json({**frames.SQUARE, "edges": [*frames.SQUARE["edges"], [0, 2]]})
    s = np.linalg.svd(compatibility_matrix(normalised(braced.positions), braced.edges), compute_uv=False)
    a = client.analyze(braced, method="sparse", gap_rtol=1e-9)
    assert a.rank_gap.last_nonzero_error <= 1e-9
    assert a.rank_gap.last_nonzero == pytest.approx(s[a.rank - 1], rel=1e-9)


def test_tetrahedron_is_rigid_in_space(client: Client) -> None:
    a = client.analyze(K4_SPACE)
    assert (a.dim, a.rank, a.zero_modes, a.rigid_body_modes, a.self_stresses) == (3, 6, 6, 6, 0)
    assert a.modes.shape == (0, 4, 3) and a.stresses.shape == (0, 6)


def check_square_mechanism(a: Analysis) -> None:
    """The 4-cycle: one nontrivial zero mode, in N(C), unit norm, ⟂ the rigid motions."""
    assert (a.rank, a.zero_modes, a.nontrivial_zero_modes, a.self_stresses) == (4, 4, 1, 0)
    assert a.modes.shape == (1, 4, 2) and not a.modes.flags.writeable
    mode = a.modes[0].ravel()
    assert np.linalg.norm(compatibility_matrix(SQUARE.positions, SQUARE.edges) @ mode) < 1e-9
    assert np.linalg.norm(mode) == pytest.approx(1.0)
    assert np.abs(rigid_generators(SQUARE.positions).T @ mode).max() < 1e-9


def test_square_has_one_mechanism(client: Client) -> None:
    check_square_mechanism(client.analyze(SQUARE))


def test_options_are_sent(client: Client) -> None:
    a = client.analyze(SQUARE, method="dense", bases=False)
    assert a.raw["method"] == "dense"
    assert a.nontrivial_zero_modes == 1 and a.modes.shape == (0, 4, 2)


def test_a_frame_given_as_json_is_accepted(client: Client) -> None:
    assert client.analyze(SQUARE.to_json()).nontrivial_zero_modes == 1


BAD_FRAMES = [
    (Frame([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 1]]), "self_loop", "edge 1"),
    (Frame([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 0]]), "duplicate_edge", "edges 0 and 1"),
    (Frame([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 5]]), "edge_out_of_range", "edge 1"),
    (Frame([[0, 0], [0, 0], [0, 1]], [[0, 1], [1, 2]]), "zero_length_bar", "edge 0"),
    (Frame([[0, 0, 0, 0], [1, 0, 0, 0]], [[0, 1]]), "invalid_request", "dim"),
]


@pytest.mark.parametrize(("frame", "code", "named"), BAD_FRAMES, ids=[c for _, c, _ in BAD_FRAMES])
def test_bad_frame_raises_with_the_services_code(client: Client, frame, code, named) -> None:
    with pytest.raises(ZeromodeError) as info:
        client.analyze(frame)
    assert (info.value.status, info.value.code) == (422, code)
    assert named in info.value.message
    assert info.value.detail["code"] == code


def test_non_finite_numbers_are_refused_before_sending(client: Client) -> None:
    with pytest.raises(ValueError, match="finite"):
        client.analyze(Frame([[0, 0], [np.nan, 0]], [[0, 1]]))


def test_async_client_does_the_same(service_url: str) -> None:
    async def scenario() -> None:
        async with AsyncClient(service_url, timeout=30.0) as client:
            health, square, triangle = await asyncio.gather(
                client.health(), client.analyze(SQUARE), client.analyze(TRIANGLE)
            )
            assert health.status == "ok"
            check_square_mechanism(square)
            assert (triangle.zero_modes, triangle.modes.shape) == (3, (0, 3, 2))
            with pytest.raises(ZeromodeError) as info:
                await client.analyze(BAD_FRAMES[0][0])
            assert (info.value.status, info.value.code) == (422, "self_loop")

    asyncio.run(scenario())


# --- the other endpoints ---


def random_constrained_pair(rng: np.random.Generator, k: int, d: int):
    """k specified (x_S, u_S) that admit the unspecified solution (x_U, u_U), and that solution.

    Each u_Si is random, then projected so that (x_Si − x_U)·(u_Si − u_U) = 0 (Eq. 1).
    """
    x_u, u_u = rng.normal(size=d), rng.normal(size=d)
    x_s, u_s = rng.normal(size=(k, d)), rng.normal(size=(k, d))
    r = x_s - x_u
    u_s -= (np.sum(r * (u_s - u_u), axis=1) / np.sum(r * r, axis=1))[:, None] * r
    return x_s, u_s, x_u, u_u


def test_solution_space_conic(client: Client) -> None:
    """d=2, k=3 independent rows of Ã: m = 2d+1−k = 2, a conic (paper, Results §1)."""
    x_s, u_s, x_u, u_u = random_constrained_pair(np.random.default_rng(7), k=3, d=2)
    space = client.solution_space(x_s, u_s, samples=8)
    assert (space.nullity, space.dimension, space.kind) == (2, 1, "conic")
    assert space.basis.shape == (5, 3) and space.quadric.shape == (3, 3)
    np.testing.assert_allclose(space.quadric, space.quadric.T, atol=1e-12)
    assert 1 <= len(space.sample_positions) <= 8
    assert (
        space.sample_positions.shape
        == space.sample_motions.shape
        == (len(space.sample_positions), 2)
    )
    # The known solution lies on the quadric: v = (x_U, u_U, x_U·u_U) = W̃ α̃ with α̃_last = 1.
    v = np.concatenate([x_u, u_u, [x_u @ u_u]])
    alpha, *_ = np.linalg.lstsq(space.basis, v, rcond=None)
    assert np.linalg.norm(space.basis @ alpha - v) < 1e-8 * np.linalg.norm(v)
    assert alpha[-1] == pytest.approx(1.0)
    assert abs(alpha @ space.quadric @ alpha) < 1e-8 * np.abs(space.quadric).max() * (alpha @ alpha)
    for x, u in zip(space.sample_positions, space.sample_motions, strict=True):
        residual = np.sum((x_s - x) * (u_s - u), axis=1)
        assert np.abs(residual).max() < 1e-8 * (1 + np.abs(x_s - x).max() * np.abs(u_s - u).max())


def test_solution_space_without_solution(client: Client) -> None:
    """d=2, k=6 generic rows: Ã is 6×5, so b ∉ R(Ã) and there is no solution."""
    rng = np.random.default_rng(3)
    with pytest.raises(ZeromodeError) as info:
        client.solution_space(rng.normal(size=(6, 2)), rng.normal(size=(6, 2)), samples=4)
    assert (info.value.status, info.value.code) == (422, "no_solution")


def test_design_outward_motion(client: Client) -> None:
    """Four specified corners with u_S = (x, 2y): a conic of solutions, so a design exists."""
    x_s = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    u_s = x_s * [1.0, 2.0]
    design = client.design(x_s, u_s, seed=0)
    frame, k = design.frame, len(x_s)
    np.testing.assert_array_equal(frame.positions[:k], x_s)
    assert frame.specified == tuple(range(k))
    assert design.modes.shape == (1, *frame.positions.shape)
    np.testing.assert_allclose(design.modes[0, :k], u_s, atol=1e-9)
    c = compatibility_matrix(frame.positions, frame.edges)
    assert np.linalg.norm(c @ design.modes[0].ravel()) < 1e-8 * np.linalg.norm(c) * np.linalg.norm(
        u_s
    )
    # Exactly d(d+1)/2 + M zero modes and no self-stress, decided from scratch.
    counts = reference_counts(frame.positions, frame.edges)
    assert (counts["zero_modes"], counts["self_stresses"]) == (3 + 1, 0)
    assert design.report["target_zero_modes"] == 4


def test_certify_answers_for_a_frame(client: Client) -> None:
    result = client.certify(K4_PLANE)
    assert result.path == "/v1/certify" and isinstance(result.raw, dict) and result.raw


@pytest.mark.parametrize("method", ["certify", "motion", "refine"])
def test_frame_endpoints_reject_a_bad_frame(client: Client, method: str) -> None:
    with pytest.raises(ZeromodeError) as info:
        getattr(client, method)(BAD_FRAMES[0][0])
    assert info.value.status == 422 and info.value.code and info.value.message


def test_motion_follows_the_square_mechanism(client: Client) -> None:
    """The 4-bar square moves as a rhombus: every bar keeps its length along the whole path."""
    mode = client.analyze(SQUARE).modes[0]
    result = client.motion(SQUARE, mode=mode, amplitude=0.2)
    path, ref = result.array("path"), result["reference_index"]
    assert path.ndim == 3 and path.shape[1:] == (4, 2) and len(path) >= 3
    np.testing.assert_allclose(path[ref], SQUARE.positions, atol=1e-12)
    assert result["parameter"][ref] == 0
    assert np.abs(path - SQUARE.positions).max() > 0.05  # it really moved
    assert relative_bar_error(path, SQUARE.edges, SQUARE.positions) < 1e-8
    assert result["max_relative_bar_error"] < 1e-8


def test_refine_keeps_the_specified_nodes_and_improves_fidelity(client: Client) -> None:
    x_s = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    u_s = x_s * [1.0, 2.0]
    designed = client.design(x_s, u_s, seed=0).frame
    result = client.refine(designed, motion=u_s, amplitude=0.1, options={"K": 4})
    refined = result.frame
    assert refined is not None
    np.testing.assert_array_equal(refined.positions[:4], x_s)
    np.testing.assert_array_equal(refined.edges, designed.edges)
    assert result["epsilon_after"] < result["epsilon_before"]
    assert relative_bar_error(result.array("path"), refined.edges, refined.positions) < 1e-6


def test_auxetic_sheet_has_the_requested_poisson_ratio(client: Client) -> None:
    result = client.design_auxetic(dim=2, cells=[2, 2], poisson_ratio=-0.5)
    frame, modes, boundary = result.frame, result.modes, result["report"]["boundary"]
    assert frame is not None and modes is not None and modes.shape == (1, *frame.positions.shape)
    c = compatibility_matrix(frame.positions, frame.edges)
    assert np.linalg.norm(c @ modes[0].ravel()) < 1e-8 * np.linalg.norm(c) * np.linalg.norm(
        modes[0]
    )
    # Linear ratio of the mode, from scratch: ε = d(gap)/gap for the boundary sets.
    eps_x, eps_y = boundary_strains(frame.positions, modes[0], boundary, finite=False)
    assert -eps_y / eps_x == pytest.approx(-0.5, abs=1e-6)
    assert result["poisson_ratio"] == pytest.approx(-0.5, abs=1e-6)
    assert sorted(state["name"] for state in result["states"]) == ["contracted", "expanded"]
    for state in result["states"]:
        moved = np.asarray(state["positions"])
        assert relative_bar_error([moved], frame.edges, frame.positions) < 1e-8  # a mechanism
        eps_x, eps_y = boundary_strains(frame.positions, moved, boundary, finite=True)
        secant = -eps_y / eps_x
        assert secant < 0 and state["poisson_ratio"] == pytest.approx(secant, rel=1e-6)


def test_auxetic_sheet_holds_its_ratio_at_finite_strain_and_carries_certificates(client: Client) -> None:
    """The client passes the pipeline's options of /v1/design/auxetic (finite_strain, certify):
    the states at ε_x = ±10 % keep the secant ν within the tolerance, measured here from the
    returned positions; the certificate's counts are the numpy rank count of the returned sheet."""
    result = client.design_auxetic(dim=2, cells=[2, 2], poisson_ratio=-0.5, certify=True,
                                   finite_strain={"strain_range": [-0.1, 0.1], "tolerance": 0.02})
    frame, boundary = result.frame, result["report"]["boundary"]
    for state in result["states"]:
        moved = np.asarray(state["positions"])
        assert relative_bar_error([moved], frame.edges, frame.positions) < 1e-8
        eps_x, eps_y = boundary_strains(frame.positions, moved, boundary, finite=True)
        assert abs(abs(eps_x) - 0.1) < 1e-9 and abs(-eps_y / eps_x + 0.5) <= 0.02
    certificate = result["report"]["certificate"]
    counts = reference_counts(frame.positions, frame.edges)
    assert certificate["analysis"]["rank"] == counts["rank"]
    assert certificate["analysis"]["self_stresses"] == counts["self_stresses"]
    margin = certificate["rigidity_margin"]
    assert margin["undesigned_zero_modes"] == 0
    assert 0 < margin["uniform"] <= margin["optimal"] * (1 + 1e-6) and margin["optimal"] <= margin["optimal_upper_bound"]


def test_allosteric_design_drives_the_target(client: Client) -> None:
    """A dilating source triangle must contract a target triangle 6 units away."""
    x_src = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    x_tgt = x_src + [6.0, 0.0]
    u_src, u_tgt = x_src - x_src.mean(axis=0), -(x_tgt - x_tgt.mean(axis=0))
    result = client.design_allosteric(
        dim=2,
        source={"positions": x_src, "motion": u_src},
        target={"positions": x_tgt, "motion": u_tgt},
    )
    frame, report = result.frame, result["report"]
    assert frame is not None and result.modes is not None
    np.testing.assert_array_equal(frame.positions[report["source"]], x_src)
    np.testing.assert_array_equal(frame.positions[report["target"]], x_tgt)
    # From scratch: d(d+1)/2 + 1 zero modes, no self-stress, and the zero mode that moves the
    # source by u_src moves the target by u_tgt.
    counts = reference_counts(frame.positions, frame.edges)
    assert (counts["zero_modes"], counts["self_stresses"]) == (4, 0)
    response = driven_response(frame.positions, frame.edges, report["source"], u_src)
    target = response[report["target"]]
    assert np.linalg.norm(target - u_tgt) < 1e-8 * np.linalg.norm(u_tgt)
    # The builder's amplification is stated, its RMS figure below the worst-direction bound.
    assert 0 < report["amplification"] <= report["amplification_worst"]


def test_two_configuration_design_realises_both(client: Client) -> None:
    """Initial and final positions of a square scaled by 1.3: both are exact realisations."""
    x = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])
    result = client.design_two_configuration(dim=2, initial=x, final=1.3 * x)
    frame = result.frame
    assert frame is not None
    final = np.asarray(result["final_positions"])
    assert relative_bar_error([final], frame.edges, frame.positions) <= 1e-12
    np.testing.assert_array_equal(final[:4], 1.3 * x)
