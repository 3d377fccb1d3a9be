"""The ε(b) curve (finite_motion.fidelity_curve) of /v1/refine and /v1/motion against an oracle
written here from the definition, for the outward square (the named example outward_2d).

ε(b) = min over configurations X with every bar at its length, and proper rigid motions R, of
‖R·X_S − (x_S + b·u_S)‖ / ‖b·u_S‖. The bar constraints are invariant under rigid motions, so the
inner minimum over R can be absorbed into X: ε(b)·‖b·u_S‖ = min ‖X_S − T‖ over the constraint
manifold, T = x_S + b·u_S. The oracle solves the Lagrange conditions of that problem,

    P_Sᵀ(X_S − T) + Σ_e λ_e ∇g_e(X) = 0,   g_e(X) = ½(|X_i − X_j|² − l_e²) = 0,

by scipy's root finder (hybrid Powell, analytic Jacobian), from every traced sample of the path,
each first moved onto the target by the best proper rigid motion (Kabsch in numpy, written here),
and keeps the smallest distance among the solutions that stay near their start (the branch the
path traced). No zeromode code computes the oracle's numbers.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import root

import zeromode as zm
from tests.client.conftest import served
from zeromode.service.rest.app import create_app
from zeromode.solver.motion.finite_motion import CURVE_SAMPLES
from zeromode_client import Client, ZeromodeError

# Amplitude of the refinement (the designer's default at 0.2 …) and the curve's samples checked.
AMPLITUDE = 0.2
CHECKED = (0.25, 0.5, 0.75, 1.0)  # the amplitudes b/a checked
# The oracle and the service solve the same minimum on the same curve: they agree to 1e-13
# (measured, absolute); the margins cover the polishing of the service's one-dimensional minimum
# (xatol 1e-12 in parameter) and the round-off of a distance near 1e-8 of the displacement.
SAME_EPSILON = 1e-9
ROUND_OFF_EPSILON = 1e-11
# A root counts when its bars and Lagrange conditions hold to this (normalised units).
KKT_ATOL = 1e-12
# A root is on the traced branch when it lies within this distance (relative to the frame's
# RMS radius) of the sample it started from.
SAME_BRANCH = 0.1


def kabsch(moving: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The proper rigid motion (a function of (n, d) point sets) that best fits the point set
    ``moving`` (k, d) to ``target`` (k, d): SVD of the centred covariance, its last axis flipped
    when the best orthogonal map is a reflection."""
    p0, q0 = moving.mean(axis=0), target.mean(axis=0)
    h = (moving - p0).T @ (target - q0)
    u, _, vt = np.linalg.svd(h)
    d = np.ones(len(h))
    d[-1] = np.sign(np.linalg.det(u @ vt))
    rotation = (u * d) @ vt
    return lambda x: (x - p0) @ rotation + q0


def rigid_distance(moving: np.ndarray, target: np.ndarray) -> float:
    """min over proper rigid motions R of ‖R·moving − target‖ (Kabsch)."""
    return float(np.linalg.norm(kabsch(moving, target)(moving) - target))


def closest_distance(sample: np.ndarray, edges: np.ndarray, lengths: np.ndarray, spec: np.ndarray, target: np.ndarray):
    """The stationary point of ‖X_S − T‖ on the constraint manifold nearest ``sample`` (aligned
    to the target first): (distance, configuration) or None when the root finder fails."""
    n, d = sample.shape
    x0 = kabsch(sample[spec], target)(sample)
    i, j = edges[:, 0], edges[:, 1]
    select = np.zeros((n, d))
    select[spec] = 1.0

    def jacobian_c(x):
        c = np.zeros((len(edges), n, d))
        diff = x[i] - x[j]
        c[np.arange(len(edges)), i] = diff
        c[np.arange(len(edges)), j] = -diff
        return c.reshape(len(edges), n * d)

    def residual(z):
        x, lam = z[: n * d].reshape(n, d), z[n * d :]
        grad = np.zeros((n, d))
        grad[spec] = x[spec] - target
        bars = 0.5 * (np.sum((x[i] - x[j]) ** 2, axis=1) - lengths**2)
        return np.concatenate([grad.ravel() + jacobian_c(x).T @ lam, bars])

    def jacobian(z):
        x, lam = z[: n * d].reshape(n, d), z[n * d :]
        hess = np.diag(select.ravel())
        for e, (a, b) in enumerate(edges):
            for p, q, sign in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
                hess[p * d : (p + 1) * d, q * d : (q + 1) * d] += sign * lam[e] * np.eye(d)
        c = jacobian_c(x)
        return np.block([[hess, c.T], [c, np.zeros((len(edges), len(edges)))]])

    grad0 = np.zeros((n, d))
    grad0[spec] = x0[spec] - target
    lam0 = np.linalg.lstsq(jacobian_c(x0).T, -grad0.ravel(), rcond=None)[0]
    sol = root(residual, np.concatenate([x0.ravel(), lam0]), jac=jacobian, method="hybr", options={"xtol": 1e-15})
    if not np.all(np.abs(residual(sol.x)) <= KKT_ATOL):
        return None
    x = sol.x[: n * d].reshape(n, d)
    return rigid_distance(x[spec], target), x


def oracle_epsilon(path: np.ndarray, edges, spec, x_s: np.ndarray, delta: np.ndarray) -> float:
    """ε of the target x_S + Δ_S over the branch of ``path`` (P, N, d): see the module docstring."""
    edges = np.asarray(edges, dtype=int)
    spec = np.asarray(spec, dtype=int)
    reference = path[0]
    lengths = np.linalg.norm(reference[edges[:, 0]] - reference[edges[:, 1]], axis=1)
    radius = np.sqrt(np.mean(np.sum((reference - reference.mean(axis=0)) ** 2, axis=1)))
    target = x_s + delta
    best = np.inf
    for sample in path:
        found = closest_distance(sample, edges, lengths, spec, target)
        if found is None:
            continue
        distance, x = found
        aligned = kabsch(sample[spec], target)(sample)
        if np.linalg.norm(x - aligned) / np.sqrt(len(x)) <= SAME_BRANCH * radius:
            best = min(best, distance)
    assert np.isfinite(best), "the oracle found no stationary point near the path"
    return best / np.linalg.norm(delta)


def check_curve(amplitudes, epsilon, path, edges, spec, x_s, delta_at_a, a) -> None:
    """The curve's amplitudes are (j/m)·a, j = 1 … m = CURVE_SAMPLES, and ε at the CHECKED ones
    is the oracle's."""
    m = CURVE_SAMPLES
    assert np.allclose(amplitudes, a * np.arange(1, m + 1) / m, rtol=1e-15, atol=0)
    for fraction in CHECKED:
        j = round(fraction * m) - 1
        expected = oracle_epsilon(path, edges, spec, x_s, fraction * delta_at_a)
        assert epsilon[j] == pytest.approx(expected, rel=SAME_EPSILON, abs=ROUND_OFF_EPSILON), fraction


@pytest.fixture(scope="module")
def outward():
    """The named example's design and its refinement (the library: the solver's Refinement)."""
    design = zm.examples.design("outward_2d")
    frame = design.frame
    x_s = frame.positions[list(frame.specified)]
    return design, zm.refine(design, x_s, amplitude=AMPLITUDE), x_s


def test_refine_curve_before_and_after_against_the_oracle(outward):
    design, refined, x_s = outward
    frame, body, solution = design.frame, refined.to_dict(), refined.solution
    curve = body["epsilon_curve"]
    delta = np.array(body["displacement"])
    assert np.allclose(delta, AMPLITUDE * x_s)  # u_S = x_S with r_S = ρ_u: Δ_S = a·x_S
    # The library's result carries the solver's curves, which the body serialises.
    assert np.array_equal(solution.curve_after.epsilon, curve["after"])
    # Before: the linear design; after: the refined frame's own motion (the oracle's starts).
    motion = zm.motion(design, amplitude=1.0, max_step=0.01)
    check_curve(curve["amplitudes"], curve["before"], np.array(motion.to_dict()["path"]), frame.edges,
                frame.specified, x_s, delta, AMPLITUDE)
    refined_motion = zm.motion(refined, amplitude=1.0, max_step=0.01)
    check_curve(curve["amplitudes"], curve["after"], np.array(refined_motion.to_dict()["path"]), frame.edges,
                frame.specified, x_s, delta, AMPLITUDE)
    # The last values are the report's ε before and after (the same measurement).
    assert curve["before"][-1] == body["epsilon_before"] and curve["after"][-1] == body["epsilon_after"]
    assert body["epsilon_after"] <= 1e-6 < body["epsilon_before"]
    # The refined path leaves the straight route in between and meets the target at a.
    assert max(curve["after"]) > 1e3 * body["epsilon_after"]


@pytest.fixture(scope="module")
def service():
    """The real app served by uvicorn on loopback, asked through the Python client."""
    with served(create_app()) as url, Client(url) as client:
        yield client


def test_motion_answers_the_curve_of_its_linear_target(service, outward):
    design, refined, x_s = outward
    frame = design.frame
    body = design.to_dict()["frame"]
    mode = design.modes[0]
    # As the designer asks it: the arrows' motion u_S (the mode's specified rows), a = 0.2.
    got = service.motion(body, mode=mode.tolist(), amplitude=0.3, on_singularity="report",
                         epsilon_curve={"amplitude": AMPLITUDE, "motion": x_s.tolist()})
    curve = got.epsilon_curve
    assert curve is not None and set(curve.curves) == {"epsilon"}
    assert not any(got["epsilon_curve"]["at_end"])
    check_curve(curve.amplitudes, curve["epsilon"], got.array("path"), frame.edges, frame.specified, x_s,
                AMPLITUDE * x_s, AMPLITUDE)
    # Its last value is the refinement's ε before (the same target, another traced path).
    assert curve["epsilon"][-1] == pytest.approx(refined.to_dict()["epsilon_before"], rel=SAME_EPSILON)
    # The default u_S: the rows of the mode followed (here u_S ∝ x_S again).
    default = service.motion(body, mode=mode.tolist(), amplitude=0.3, epsilon_curve={"amplitude": AMPLITUDE})
    assert np.allclose(default.epsilon_curve["epsilon"], curve["epsilon"], rtol=1e-9, atol=0)
    # Without the option the answer has no curve.
    assert service.motion(body, amplitude=0.3).epsilon_curve is None


def test_refine_through_the_client_carries_the_curve(service, outward):
    design, _, x_s = outward
    got = service.refine(design.to_dict()["frame"], motion=x_s.tolist(), amplitude=AMPLITUDE)
    curve = got.epsilon_curve
    assert set(curve.curves) == {"before", "after"} and curve.amplitudes[-1] == got["amplitude"]
    assert curve["before"][-1] == got["epsilon_before"] and curve["after"][-1] == got["epsilon_after"]


@pytest.mark.parametrize(
    ("change", "code"),
    [
        ({"specified": []}, "too_few_specified"),
        ({"motion": [[1.0, 0.0]]}, "invalid_shape"),
    ],
)
def test_motion_curve_refusals(service, outward, change, code):
    design, _, x_s = outward
    body = design.to_dict()["frame"]
    option = {"amplitude": AMPLITUDE, "motion": change.get("motion", x_s.tolist())}
    if "specified" in change:
        body = {**body, "specified": change["specified"]}
    with pytest.raises(ZeromodeError) as err:
        service.motion(body, amplitude=0.3, epsilon_curve=option)
    assert err.value.status == 422 and err.value.code == code


def test_a_rigid_target_has_no_curve(outward):
    """A target that is a rigid motion of x_S is met without tracing (ε = 0): no path, no curve."""
    design, _, x_s = outward
    turn = np.array([[0.0, -1.0], [1.0, 0.0]])
    body = zm.refine(design, targets=(x_s @ turn.T + 0.5).tolist()).to_dict()
    assert body["ipopt_status"] == "not_needed" and body["epsilon_after"] == 0.0
    assert body["epsilon_curve"] is None
