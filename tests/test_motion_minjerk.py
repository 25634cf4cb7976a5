"""MinJerk: boundary conditions, optimality, the paper's c2 error, vectorised shapes, re-planning."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import array_shapes, arrays

from masonry.errors import PlanningError
from masonry.motion import MIN_T_GO_S, MinJerk, paper_coefficients


def vec(bound: float) -> st.SearchStrategy[np.ndarray]:
    return arrays(np.float64, 3, elements=st.floats(-bound, bound, allow_nan=False, allow_subnormal=False))


states = st.tuples(vec(5.0), vec(3.0), vec(5.0), vec(5.0), vec(3.0), vec(5.0), st.floats(0.3, 15.0))


def quad(f, T: float, n: int = 24) -> float:
    """Gauss-Legendre integral of f over [0, T] (exact for polynomials of degree < 2n)."""
    nodes, weights = np.polynomial.legendre.leggauss(n)
    half = T / 2.0
    return float(half * np.sum(weights * f(half * (nodes + 1.0))))


@given(states)
def test_boundary_conditions_hold(state) -> None:
    r0, v0, a0, rf, vf, af, T = state
    traj = MinJerk(r0, v0, a0, rf, vf, af, T)
    for got, want in (
        (traj.position(0.0), r0),
        (traj.velocity(0.0), v0),
        (traj.acceleration(0.0), a0),
        (traj.position(T), rf),
        (traj.velocity(T), vf),
        (traj.acceleration(T), af),
    ):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


@given(states, st.floats(0.0, 1.0))
def test_matches_the_corrected_paper_quintic_in_t_go(state, frac) -> None:
    r0, v0, a0, rf, vf, af, T = state
    traj = MinJerk(r0, v0, a0, rf, vf, af, T)
    c1, c2, c3 = paper_coefficients(r0, v0, a0, rf, vf, af, T)
    t_go = T * (1.0 - frac)
    paper_r = c3 * t_go**5 + c2 * t_go**4 + c1 * t_go**3 + af * t_go**2 / 2.0 - vf * t_go + rf
    np.testing.assert_allclose(traj.position(T - t_go), paper_r, rtol=0, atol=1e-8)


def test_paper_c2_as_printed_breaks_the_initial_position() -> None:
    r0, v0, a0 = np.array([0.0, 0.0, 1.2]), np.zeros(3), np.array([0.0, 0.0, 0.5])
    rf, vf, af = np.array([0.3, -0.2, 0.15]), np.zeros(3), np.zeros(3)
    T = 7.0

    def r_at_start(c1, c2, c3):
        return c3 * T**5 + c2 * T**4 + c1 * T**3 + af * T**2 / 2 - vf * T + rf

    printed = r_at_start(*paper_coefficients(r0, v0, a0, rf, vf, af, T, as_printed=True))
    corrected = r_at_start(*paper_coefficients(r0, v0, a0, rf, vf, af, T))
    np.testing.assert_allclose(corrected, r0, atol=1e-9)
    # The printed +Z_a0/t_go^2 moves r(0) by exactly 2 (a0 - af) T^2: 49 m here for a 0.5 m/s^2 start.
    np.testing.assert_allclose(printed - r0, 2.0 * (a0 - af) * T**2, atol=1e-9)
    assert np.linalg.norm(printed - r0) > 1.0
    # With a0 == af the printed form is right: the error only shows when the accelerations differ.
    same = r_at_start(*paper_coefficients(r0, v0, af, rf, vf, af, T, as_printed=True))
    np.testing.assert_allclose(same, r0, atol=1e-9)


bump_coeffs = arrays(np.float64, (4, 3), elements=st.floats(-1.0, 1.0, allow_nan=False))


@given(states, bump_coeffs, st.floats(1e-3, 1.0), st.integers(1, 4))
def test_every_boundary_preserving_perturbation_costs_more(state, coeffs, eps, k) -> None:
    r0, v0, a0, rf, vf, af, T = state
    traj = MinJerk(r0, v0, a0, rf, vf, af, T)
    peak = np.max(np.abs(coeffs))
    coeffs = coeffs / peak if peak > 1e-3 else np.ones((4, 3))

    # eta(t) = [(t/T)^3 (1 - t/T)^3 * P(t/T) + sin(k pi t/T)^3 * coeffs[0]] keeps r, v, a at both ends.
    # Its jerk is differentiated exactly (numpy polynomials, and the sin^3 identity).
    u = np.polynomial.Polynomial([0.0, 1.0 / T])
    base = u**3 * (1 - u) ** 3
    polys = [base * np.polynomial.Polynomial(coeffs[:, axis]) for axis in range(3)]
    jerk_polys = [p.deriv(3) for p in polys]
    w = k * np.pi / T

    def sin3_jerk(t):
        # d^3/dt^3 sin^3(w t) with sin^3 x = (3 sin x - sin 3x) / 4.
        return (-3.0 * w**3 * np.cos(w * t) + 27.0 * w**3 * np.cos(3 * w * t)) / 4.0

    def eta_jerk(t):
        return np.stack(
            [jp(t) + coeffs[0, axis] * sin3_jerk(t) for axis, jp in enumerate(jerk_polys)], axis=-1
        )

    def eta_value(t):
        return np.stack(
            [p(t) + coeffs[0, axis] * np.sin(w * t) ** 3 for axis, p in enumerate(polys)], axis=-1
        )

    # The perturbation really keeps the boundary conditions (value, and through its construction v, a).
    assert np.allclose(eta_value(np.array([0.0, T])), 0.0, atol=1e-9)

    base_cost = quad(lambda t: 0.5 * np.sum(traj.jerk(t) ** 2, axis=-1), T)
    perturbed = quad(lambda t: 0.5 * np.sum((traj.jerk(t) + eps * eta_jerk(t)) ** 2, axis=-1), T, n=64)
    bump_cost = quad(lambda t: 0.5 * np.sum(eta_jerk(t) ** 2, axis=-1), T, n=64)
    # First variation vanishes: J(x + eps eta) = J(x) + eps^2 J(eta) exactly, hence strictly larger.
    assert perturbed == pytest.approx(base_cost + eps**2 * bump_cost, rel=1e-9, abs=1e-9)
    assert perturbed > base_cost
    assert traj.cost() == pytest.approx(base_cost, rel=1e-10, abs=1e-12)


def test_cost_of_rest_to_rest_move_matches_the_textbook_value() -> None:
    # Rest-to-rest over distance D in time T: 1/2 * integral jerk^2 = 360 D^2 / T^5.
    traj = MinJerk([0, 0, 0], [0, 0, 0], [0, 0, 0], [2.0, 0, 0], [0, 0, 0], [0, 0, 0], 4.0)
    assert traj.cost() == pytest.approx(360.0 * 4.0 / 4.0**5, rel=1e-12)


@given(array_shapes(min_dims=0, max_dims=3, max_side=4))
def test_vectorised_shapes(shape) -> None:
    traj = MinJerk([0, 0, 1], [1, 0, 0], [0, 1, 0], [1, 2, 0], [0, 0, 0], [0, 0, 0], 3.0)
    t = np.random.default_rng(0).uniform(-1.0, 4.0, size=shape)
    for method in (traj.position, traj.velocity, traj.acceleration, traj.jerk):
        out = method(t)
        assert out.shape == (*tuple(shape), 3)
        flat = t.reshape(-1)
        rows = out.reshape(-1, 3)
        for i in range(min(len(flat), 5)):
            np.testing.assert_allclose(rows[i], method(float(flat[i])), atol=1e-12)


def test_scalar_and_list_inputs() -> None:
    traj = MinJerk([0, 0, 1], [0, 0, 0], [0, 0, 0], [1, 1, 0], [0, 0, 0], [0, 0, 0], 2.0)
    assert traj.position(1.0).shape == (3,)
    assert traj.position([0.0, 1.0, 2.0]).shape == (3, 3)
    assert traj.position(np.float64(0.5)).shape == (3,)


def test_derivatives_are_consistent() -> None:
    traj = MinJerk([0, 0, 1], [0.3, 0, 0], [0, 0.4, 0], [1, 1, 0], [0, 0, -0.1], [0, 0, 0.2], 2.5)
    t = np.linspace(0.05, 2.45, 17)
    h = 1e-5
    for f, df in (
        (traj.position, traj.velocity),
        (traj.velocity, traj.acceleration),
        (traj.acceleration, traj.jerk),
    ):
        np.testing.assert_allclose((f(t + h) - f(t - h)) / (2 * h), df(t), atol=1e-6)


def test_outside_the_horizon_it_continues_at_constant_acceleration() -> None:
    rf, vf, af = np.array([1.0, 2.0, 0.0]), np.array([0.5, 0.0, 0.0]), np.array([0.0, 0.0, 0.2])
    traj = MinJerk([0, 0, 1], [0, 0, 0], [0, 0, 0], rf, vf, af, 2.0)
    np.testing.assert_allclose(traj.position(3.0), rf + vf + af / 2.0, atol=1e-12)
    np.testing.assert_allclose(traj.velocity(3.0), vf + af, atol=1e-12)
    np.testing.assert_allclose(traj.acceleration(3.0), af, atol=1e-12)
    np.testing.assert_allclose(traj.jerk(3.0), 0.0)
    np.testing.assert_allclose(traj.position(-1.0), [0, 0, 1], atol=1e-12)
    rest = MinJerk([0, 0, 1], [0, 0, 0], [0, 0, 0], [1, 1, 0], [0, 0, 0], [0, 0, 0], 2.0)
    np.testing.assert_allclose(rest.position(100.0), [1, 1, 0], atol=1e-12)


@given(states, st.floats(0.0, 0.95))
def test_replan_from_its_own_state_gives_the_same_trajectory(state, frac) -> None:
    r0, v0, a0, rf, vf, af, T = state
    traj = MinJerk(r0, v0, a0, rf, vf, af, T)
    t = frac * T
    assume(T - t >= MIN_T_GO_S)
    again = traj.replan(*traj.state(t), T - t)
    tau = np.linspace(0.0, T - t, 9)
    np.testing.assert_allclose(again.position(tau), traj.position(t + tau), rtol=1e-9, atol=1e-8)
    np.testing.assert_allclose(again.rf, rf)
    np.testing.assert_allclose(again.vf, vf)
    np.testing.assert_allclose(again.af, af)


def test_replan_floors_the_remaining_time() -> None:
    traj = MinJerk([0, 0, 1.2], [0, 0, 0], [0, 0, 0], [0, 0, 0.1], [0, 0, 0], [0, 0, 0], 7.0)
    late = traj.replan([0.01, 0, 0.12], [0, 0, -0.05], [0, 0, 0], -0.5)
    assert late.duration_s == MIN_T_GO_S
    assert np.all(np.isfinite(late.coefficients))
    np.testing.assert_allclose(late.position(late.duration_s), [0, 0, 0.1], atol=1e-12)
    assert traj.replan([0, 0, 1], [0, 0, 0], [0, 0, 0], 0.0, min_t_go_s=0.5).duration_s == 0.5
    with pytest.raises(PlanningError):
        traj.replan([0, 0, 1], [0, 0, 0], [0, 0, 0], float("nan"))


def test_guidance_law_rejects_disturbances() -> None:
    """Closed loop as in the paper: re-solve from the disturbed state each tick, apply the jerk, reach the target."""
    rng = np.random.default_rng(7)
    target = np.array([0.4, -0.3, 0.12])
    traj = MinJerk([0, 0, 1.2], [0, 0, 0], [0, 0, 0], target, [0, 0, 0], [0, 0, 0], 7.0)
    r, v, a = traj.state(0.0)
    dt = 0.02
    steps = round(7.0 / dt)
    for i in range(steps):
        plan = traj.replan(r, v, a, 7.0 - i * dt)
        # Integrate the plan's jerk exactly over one tick (the plan is a polynomial), then disturb the velocity.
        r, v, a = plan.state(dt)
        v = v + rng.normal(0.0, 0.002, 3)
    assert np.linalg.norm(r - target) < 0.005
    assert np.linalg.norm(v) < 0.02


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"duration_s": 0.0}, "duration_s"),
        ({"duration_s": float("inf")}, "duration_s"),
        ({"r0": [0.0, 1.0]}, "r0"),
        ({"vf": [0.0, float("nan"), 0.0]}, "vf"),
    ],
)
def test_bad_arguments_raise_planning_error(kwargs, fragment) -> None:
    args = {
        "r0": [0, 0, 0],
        "v0": [0, 0, 0],
        "a0": [0, 0, 0],
        "rf": [1, 0, 0],
        "vf": [0, 0, 0],
        "af": [0, 0, 0],
    }
    args["duration_s"] = 1.0
    args.update(kwargs)
    with pytest.raises(PlanningError, match=fragment):
        MinJerk(**args)


def test_states_are_read_only() -> None:
    traj = MinJerk([0, 0, 0], [0, 0, 0], [0, 0, 0], [1, 0, 0], [0, 0, 0], [0, 0, 0], 1.0)
    with pytest.raises(ValueError):
        traj.rf[0] = 5.0
    with pytest.raises(AttributeError):
        traj.duration_s = 3.0  # type: ignore[misc]


@given(states, st.floats(-5.0, 40.0))
def test_sample_floats_is_the_vectorised_evaluation_bit_for_bit(state, t) -> None:
    r0, v0, a0, rf, vf, af, T = state
    traj = MinJerk(r0, v0, a0, rf, vf, af, T)
    p, v, a = traj.sample_floats(t)
    tc = min(max(t, 0.0), T)  # held at the ends
    assert p == tuple(traj.position(tc).tolist())
    assert v == tuple(traj.velocity(tc).tolist())
    assert a == tuple(traj.acceleration(tc).tolist())
    assert all(type(x) is float for x in (*p, *v, *a))
