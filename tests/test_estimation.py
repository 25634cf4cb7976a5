"""Estimation math: the exact marker filter against the paper's BFGS, pose from tags, moving window, confidence."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from masonry.errors import InputError, PerceptionError
from masonry.perception import (
    C_TH,
    EstimatorConfig,
    PoseWindow,
    TagPose,
    estimate_brick_pose,
    marker_cost,
    refine_markers,
    refine_markers_bfgs,
    yaw_about_rad,
)


def vec(bound: float) -> st.SearchStrategy[np.ndarray]:
    return arrays(np.float64, 3, elements=st.floats(-bound, bound, allow_nan=False, allow_subnormal=False))


unit_vectors = vec(1.0).filter(lambda v: np.linalg.norm(v) > 0.1).map(lambda v: v / np.linalg.norm(v))
weights = st.floats(0.05, 10.0)


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def z_onto(up: np.ndarray) -> np.ndarray:
    """The smallest rotation taking z onto the unit vector ``up`` (the yaw convention's reference frame)."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(up @ z)
    if c < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    k = np.cross(z, up)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    one_plus_c = float(k @ k) / (1.0 - c) if c < 0.0 else 1.0 + c  # no cancellation near -z
    return np.eye(3) + K + K @ K / one_plus_c


def angle_diff(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


# --- the filter -------------------------------------------------------------------------------------------------


@given(
    vec(2.0), vec(2.0), st.floats(0.0, 0.5, allow_subnormal=False), weights, weights, weights, unit_vectors
)
def test_filter_is_never_worse_than_bfgs(p1, p2, spacing, w_prox, w_dist, w_plane, up) -> None:
    args = (spacing, w_prox, w_dist, w_plane, up)
    ours = marker_cost(*refine_markers(p1, p2, *args), p1, p2, *args)
    bfgs = marker_cost(*refine_markers_bfgs(p1, p2, *args, fallback=False), p1, p2, *args)
    assert ours <= bfgs + 1e-9


@given(
    vec(0.3),
    vec(0.3),
    st.floats(0.0, 0.5, allow_subnormal=False),
    weights,
    st.sampled_from([0.0, 0.3, 1.0, 4.0]),
    st.sampled_from([0.0, 0.3, 1.0, 4.0]),
    unit_vectors,
)
def test_filter_is_the_global_minimum(p1, p2, spacing, w_prox, w_dist, w_plane, up) -> None:
    """No BFGS start (raw, swapped, random) and no nearby point does better, also with zero weights."""
    args = (spacing, w_prox, w_dist, w_plane, up)
    h1, h2 = refine_markers(p1, p2, *args)
    ours = marker_cost(h1, h2, p1, p2, *args)
    rng = np.random.default_rng(0)
    starts = [(p2, p1), (p1 + rng.normal(0, 0.2, 3), p2 + rng.normal(0, 0.2, 3))]
    from scipy.optimize import minimize

    for s1, s2 in starts:
        res = minimize(
            lambda x: marker_cost(x[:3], x[3:], p1, p2, *args), np.concatenate([s1, s2]), method="BFGS"
        )
        assert ours <= res.fun + 1e-9
    for _ in range(20):
        d1, d2 = rng.normal(0, 1e-3, 3), rng.normal(0, 1e-3, 3)
        assert ours <= marker_cost(h1 + d1, h2 + d2, p1, p2, *args) + 1e-12


@given(
    vec(2.0), vec(2.0), st.floats(0.0, 0.5, allow_subnormal=False), weights, weights, weights, unit_vectors
)
def test_filter_keeps_the_measured_midpoint(p1, p2, spacing, w_prox, w_dist, w_plane, up) -> None:
    h1, h2 = refine_markers(p1, p2, spacing, w_prox, w_dist, w_plane, up)
    np.testing.assert_allclose((h1 + h2) / 2.0, (p1 + p2) / 2.0, atol=1e-12)
    assert np.all(np.isfinite(h1)) and np.all(np.isfinite(h2))


def test_consistent_measurements_are_left_alone() -> None:
    p1, p2 = np.array([0.3, 0.1, 1.2]), np.array([0.3 - 0.175 * 0.6, 0.1 - 0.175 * 0.8, 1.2])
    h1, h2 = refine_markers(p1, p2, 0.175)
    np.testing.assert_allclose(h1, p1, atol=1e-12)
    np.testing.assert_allclose(h2, p2, atol=1e-12)


def test_filter_pulls_toward_the_brick_geometry() -> None:
    """Depth noise tilts the marker-to-marker vector; the filter flattens it and restores the spacing."""
    p1, p2 = np.array([0.10, 0.0, 1.23]), np.array([-0.10, 0.0, 1.19])
    h1, h2 = refine_markers(p1, p2, 0.175)
    assert abs((h1 - h2)[2]) < 0.6 * abs((p1 - p2)[2])
    assert abs(np.linalg.norm(h1 - h2) - 0.175) < abs(np.linalg.norm(p1 - p2) - 0.175)


@pytest.mark.parametrize(
    ("p1", "p2"),
    [
        ([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),  # coincident detections
        ([0.0, 0.0, 1.1], [0.0, 0.0, 1.0]),  # difference along the normal: in-plane direction undetermined
        ([0.0, 0.0, 1.0], [0.0, 0.0, 1.5]),
    ],
)
def test_degenerate_measurements_reach_the_minimum(p1, p2) -> None:
    args = (0.175, 2.0, 1.0, 1.0, (0.0, 0.0, 1.0))
    h1, h2 = refine_markers(p1, p2, *args)
    ours = marker_cost(h1, h2, p1, p2, *args)
    rng = np.random.default_rng(3)
    from scipy.optimize import minimize

    for _ in range(4):
        x0 = np.concatenate([p1, p2]) + rng.normal(0, 0.05, 6)
        res = minimize(lambda x: marker_cost(x[:3], x[3:], p1, p2, *args), x0, method="BFGS")
        assert ours <= res.fun + 1e-9
    np.testing.assert_allclose((h1 + h2) / 2, (np.add(p1, p2)) / 2, atol=1e-12)


@given(vec(1.0), vec(1.0), unit_vectors, st.floats(-math.pi, math.pi), vec(3.0))
def test_filter_commutes_with_rigid_motions(p1, p2, up, angle, shift) -> None:
    axis = np.cross(up, [0.3, -0.5, 0.8])
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([1.0, 0.0, 0.0])
    axis = axis / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    h1, h2 = refine_markers(p1, p2, 0.175, up=up)
    g1, g2 = refine_markers(R @ p1 + shift, R @ p2 + shift, 0.175, up=R @ up)
    if np.linalg.norm(p1 - p2 - ((p1 - p2) @ up) * up) < 1e-6:
        return  # in-plane direction arbitrary: only the cost is invariant there
    np.testing.assert_allclose(g1, R @ h1 + shift, atol=1e-9)
    np.testing.assert_allclose(g2, R @ h2 + shift, atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"w_prox": 0.0}, "w_prox"),
        ({"w_dist": -1.0}, "w_dist"),
        ({"w_plane": float("nan")}, "w_plane"),
        ({"spacing_m": -0.1}, "spacing_m"),
        ({"up": (0.0, 0.0, 0.0)}, "up"),
        ({"p1": [0.0, 1.0]}, "p1"),
        ({"p2": [0.0, float("inf"), 1.0]}, "p2"),
    ],
)
def test_filter_rejects_bad_input(kwargs, fragment) -> None:
    args = {"p1": [0.1, 0, 1], "p2": [-0.1, 0, 1], "spacing_m": 0.175}
    args.update(kwargs)
    with pytest.raises(InputError, match=fragment):
        refine_markers(**args)


def test_bfgs_reference_falls_back_to_raw_detections_on_failure(monkeypatch) -> None:
    import scipy.optimize

    class Failed:
        success = False
        x = np.full(6, 9.0)

    monkeypatch.setattr(scipy.optimize, "minimize", lambda *a, **k: Failed())
    p1, p2 = np.array([0.1, 0.0, 1.0]), np.array([-0.1, 0.0, 1.0])
    r1, r2 = refine_markers_bfgs(p1, p2, 0.175)
    np.testing.assert_array_equal(r1, p1)
    np.testing.assert_array_equal(r2, p2)


# --- pose from tags ---------------------------------------------------------------------------------------------


def brick_tags(
    center: np.ndarray, R: np.ndarray, k: int = 3, spacing: float = 0.175
) -> tuple[TagPose, TagPose]:
    x = R[:, 0]
    return (
        TagPose(2 * k, center + x * spacing / 2, R.copy()),
        TagPose(2 * k + 1, center - x * spacing / 2, R.copy()),
    )


orientations = st.tuples(
    st.floats(-math.pi, math.pi), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1)
)  # yaw, and tilts up to ~6 degrees


@given(orientations, vec(1.0))
def test_single_tag_fallback_in_every_orientation(orientation, center) -> None:
    yaw, roll, pitch = orientation
    R = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)
    center = center + np.array([0.0, 0.0, 1.2])
    t1, t2 = brick_tags(center, R)
    for alone in ((t1, None), (None, t2), (t2, None)):
        est = estimate_brick_pose(*alone)
        assert est is not None
        assert est.brick_id == 3
        np.testing.assert_allclose(est.center_m, center, atol=1e-12)
        # The x axis of Rz(yaw) Ry Rx projects onto the x-y plane exactly along yaw.
        assert angle_diff(est.yaw_rad, yaw) < 1e-9
        assert est.tags == ((alone[0] or alone[1]).marker_id,)


@given(orientations, vec(1.0))
def test_both_tags_give_the_exact_pose_without_noise(orientation, center) -> None:
    yaw, roll, pitch = orientation
    R = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)
    t1, t2 = brick_tags(center + np.array([0.0, 0.0, 1.2]), R)
    for a, b in ((t1, t2), (t2, t1)):
        est = estimate_brick_pose(a, b, EstimatorConfig())
        assert est is not None
        np.testing.assert_allclose(est.center_m, center + np.array([0.0, 0.0, 1.2]), atol=1e-12)
        assert angle_diff(est.yaw_rad, yaw) < 1e-9
        assert est.tags == (6, 7)


@given(unit_vectors, st.floats(-math.pi, math.pi), vec(1.0))
def test_yaw_is_measured_about_any_up_axis(up, yaw, center) -> None:
    R = z_onto(up) @ rot_z(yaw)
    config = EstimatorConfig(up=tuple(up))
    t1, t2 = brick_tags(center, R, k=0)
    for pair in ((t1, t2), (t1, None), (None, t2)):
        est = estimate_brick_pose(*pair, config)
        assert est is not None
        assert angle_diff(est.yaw_rad, yaw) < 1e-7
        np.testing.assert_allclose(est.center_m, center, atol=1e-12)


def test_camera_frame_convention_looking_down() -> None:
    """Camera above the brick looking down (x right, y down): brick +x along image x gives yaw 0."""
    R_cam_brick = np.diag([1.0, -1.0, -1.0])  # brick z (up) points back at the camera
    t1, t2 = brick_tags(np.array([0.01, -0.02, 1.13]), R_cam_brick)
    est = estimate_brick_pose(t1, t2)
    assert est is not None and est.yaw_rad == pytest.approx(0.0)
    R_cam_brick = rot_z(math.pi / 2) @ np.diag([1.0, -1.0, -1.0])  # brick +x along image y (down)
    est = estimate_brick_pose(*brick_tags(np.zeros(3), R_cam_brick))
    assert est is not None and est.yaw_rad == pytest.approx(math.pi / 2)


def test_no_tags_gives_none_and_mismatched_tags_raise() -> None:
    assert estimate_brick_pose(None, None) is None
    t1, _ = brick_tags(np.zeros(3), np.eye(3), k=1)
    _, other = brick_tags(np.zeros(3), np.eye(3), k=2)
    with pytest.raises(PerceptionError, match="not the two markers"):
        estimate_brick_pose(t1, other)
    with pytest.raises(PerceptionError):
        estimate_brick_pose(t1, t1)


def test_filter_restores_geometry_but_leaves_the_pose_unchanged() -> None:
    """Under noise the filter flattens and re-spaces the markers, yet centre and yaw are the raw ones.

    The cost separates: the midpoint is kept, and the in-plane direction of p1 - p2 is kept (only its length and
    normal component move), so the paper's filter cannot change the two-tag pose when yaw is measured about n.
    """
    rng = np.random.default_rng(11)
    raw_gap, refined_gap, raw_tilt, refined_tilt = [], [], [], []
    for _ in range(200):
        R = rot_z(rng.uniform(-math.pi, math.pi))
        t1, t2 = brick_tags(np.array([0.0, 0.0, 1.2]), R)
        noisy = [
            TagPose(t.marker_id, t.position_m + rng.normal(0, [0.003, 0.003, 0.02]), t.R_cam_marker)
            for t in (t1, t2)
        ]
        p1, p2 = noisy[0].position_m, noisy[1].position_m
        h1, h2 = refine_markers(p1, p2, 0.175)
        raw_gap.append(abs(np.linalg.norm(p1 - p2) - 0.175))
        refined_gap.append(abs(np.linalg.norm(h1 - h2) - 0.175))
        raw_tilt.append(abs((p1 - p2)[2]))
        refined_tilt.append(abs((h1 - h2)[2]))
        est = estimate_brick_pose(*noisy)
        assert est is not None
        np.testing.assert_allclose(est.center_m, (p1 + p2) / 2, atol=1e-12)
        assert angle_diff(est.yaw_rad, math.atan2((p1 - p2)[1], (p1 - p2)[0])) < 1e-12
    assert np.mean(refined_gap) < 0.6 * np.mean(raw_gap)
    assert np.mean(refined_tilt) < 0.6 * np.mean(raw_tilt)


def test_estimator_config_defaults_and_validation() -> None:
    cfg = EstimatorConfig()
    assert (cfg.spacing_m, cfg.w_prox, cfg.w_dist, cfg.w_plane, cfg.up) == (
        0.175,
        2.0,
        1.0,
        1.0,
        (0.0, 0.0, 1.0),
    )
    assert EstimatorConfig(up=(0, 0, 5)).up == (0.0, 0.0, 1.0)
    with pytest.raises(InputError, match="spacing_m"):
        EstimatorConfig(spacing_m=-1.0)
    with pytest.raises(InputError, match="up"):
        EstimatorConfig(up=(0.0, 0.0, 0.0))


@given(vec(1.0).filter(lambda v: np.linalg.norm(v[:2]) > 1e-6))
def test_yaw_about_z_is_atan2(direction) -> None:
    assert yaw_about_rad(direction) == pytest.approx(math.atan2(direction[1], direction[0]), abs=1e-12)
    assert yaw_about_rad(direction, (0, 0, -1)) == pytest.approx(
        math.atan2(-direction[1], direction[0]), abs=1e-12
    )


@given(vec(1.0), unit_vectors)
@example(np.array([1.0, 1.0, 1.0]), np.array([1e-5, 0.0, -1.0]))  # up near -z: the quotient's cancellation
def test_yaw_convention_matches_the_image_pipeline(direction, up) -> None:
    assume(np.linalg.norm(direction - (direction @ up) * up) > 1e-3)  # the angle of a vector along up is moot
    from masonry.perception import aruco

    assert angle_diff(yaw_about_rad(direction, up), aruco.yaw_about_rad(direction, up)) < 1e-9


# --- moving window and confidence -------------------------------------------------------------------------------


def test_paper_defaults() -> None:
    window = PoseWindow()
    assert (window.size, window.sigma_tol_m, C_TH) == (30, 0.04, 0.75)


@given(
    st.lists(st.tuples(vec(0.1), st.floats(-math.pi, math.pi)), min_size=0, max_size=45), st.integers(2, 30)
)
def test_confidence_formula(samples, size) -> None:
    window = PoseWindow(size=size, sigma_tol_m=0.04)
    for center, yaw in samples:
        window.add(center, yaw)
    kept = samples[-size:]
    assert window.count == len(kept)
    if len(kept) < 2:
        assert window.confidence() is None
        return
    centers = np.array([c for c, _ in kept])
    sigma_max = max(np.std(centers[:, 0], ddof=1), np.std(centers[:, 1], ddof=1))
    expected = 1.0 - min(1.0, sigma_max / 0.04)
    c = window.confidence()
    assert c is not None and 0.0 <= c <= 1.0
    assert c == pytest.approx(expected, abs=1e-12)
    mean_center, mean_yaw = window.mean()
    np.testing.assert_allclose(mean_center, centers.mean(axis=0), atol=1e-12)
    yaws = np.array([y for _, y in kept])
    if np.hypot(np.sin(yaws).sum(), np.cos(yaws).sum()) > 1e-6:
        assert mean_yaw == pytest.approx(math.atan2(np.sin(yaws).sum(), np.cos(yaws).sum()), abs=1e-9)


def test_confidence_examples() -> None:
    window = PoseWindow(size=4, sigma_tol_m=0.04)
    window.add((0.0, 0.0, 1.0), 0.0)
    assert window.confidence() is None
    window.add((0.0, 0.0, 1.0), 0.0)
    assert window.confidence() == 1.0
    window.add((0.0, 0.0, 5.0), 0.0)  # z spread does not count
    assert window.confidence() == 1.0
    window.clear()
    for x in (0.0, 0.02):  # sample std 0.01414: C = 1 - 0.3536
        window.add((x, 0.0, 1.0), 0.0)
    assert window.confidence() == pytest.approx(1.0 - math.sqrt(2) * 0.01 / 0.04)
    assert not window.confident()
    window.add((1.0, 0.0, 1.0), 0.0)
    assert window.confidence() == 0.0


def test_yaw_mean_is_circular() -> None:
    window = PoseWindow()
    for yaw in (math.pi - 0.1, -math.pi + 0.1, math.pi - 0.05, -math.pi + 0.05):
        window.add((0.0, 0.0, 0.0), yaw)
    _, yaw = window.mean()
    assert angle_diff(yaw, math.pi) < 1e-12


def test_window_errors() -> None:
    with pytest.raises(PerceptionError, match="no brick estimate"):
        PoseWindow().mean()
    with pytest.raises(InputError, match="size"):
        PoseWindow(size=1)
    with pytest.raises(InputError, match="sigma_tol_m"):
        PoseWindow(sigma_tol_m=0.0)
    with pytest.raises(InputError, match="center_m"):
        PoseWindow().add((0.0, float("nan"), 0.0), 0.0)


def test_single_tag_with_a_broken_rotation_raises() -> None:
    with pytest.raises(PerceptionError, match="marker 4 has an invalid rotation"):
        estimate_brick_pose(TagPose(4, np.zeros(3), np.zeros((3, 3))), None)
    with pytest.raises(PerceptionError, match="invalid rotation"):
        estimate_brick_pose(None, TagPose(5, np.zeros(3), np.eye(2)))


def test_pure_packages_import_no_heavy_library() -> None:
    """The estimation math and the motion core import neither OpenCV nor scipy (scipy only inside the reference)."""
    import subprocess
    import sys

    code = (
        "import sys; import masonry.perception, masonry.motion; "
        "from masonry.perception import refine_markers, estimate_brick_pose, PoseWindow, EstimatorConfig, C_TH; "
        "from masonry.motion import MinJerk, PID, PIDGains, AxisGains; "
        "print(','.join(m for m in ('cv2', 'scipy', 'matplotlib') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_subpackage_all_resolves() -> None:
    import masonry.motion
    import masonry.perception.estimation

    for module in (masonry.motion, masonry.perception.estimation):
        assert len(set(module.__all__)) == len(module.__all__)
        assert all(hasattr(module, name) for name in module.__all__)


@pytest.mark.parametrize("eps", [0.0, 3e-16, -4e-16, 1e-15])
def test_filter_with_the_markers_along_the_normal_is_the_optimum(eps) -> None:
    """The measured markers one above the other along ``up``: what is left off the normal is rounding noise, and
    the filter must not take its direction for the markers' (it is not even perpendicular to ``up``)."""
    p1, p2 = np.array([0.0, 0.0, 0.0]), np.array([0.5, 1.0, 0.0])
    up = np.array([1.0 / math.sqrt(5.0) + eps, 2.0 / math.sqrt(5.0), 0.0])
    args = (0.5, 1.0, 1.0, 2.0, up)
    ours = marker_cost(*refine_markers(p1, p2, *args), p1, p2, *args)
    bfgs = marker_cost(*refine_markers_bfgs(p1, p2, *args, fallback=False), p1, p2, *args)
    assert ours <= bfgs + 1e-9
