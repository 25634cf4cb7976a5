"""ArUco detection and the joint brick pose fit, measured on rendered frames against the truth."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from masonry.blueprint import MarkerSpec
from masonry.errors import InputError, PerceptionError
from masonry.perception.aruco import (
    aruco_dictionary,
    brick_corner_layout,
    detect_tags,
    estimate_bricks,
    yaw_about_rad,
)
from masonry.perception.render import RenderedBrick, look_down, random_view, render_frame
from masonry.perception.types import CameraIntrinsics

INTR = CameraIntrinsics(600.0, 600.0, 319.5, 239.5)
MARKERS = MarkerSpec()


def wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def truth_in_camera(T: np.ndarray, brick: RenderedBrick) -> tuple[np.ndarray, float, np.ndarray]:
    """Top-face centre (camera frame), yaw about the optical axis, and the brick's +x axis (camera frame)."""
    R_cw = T[:3, :3].T
    top = np.asarray(brick.position_m) + np.array([0.0, 0.0, brick.size_m[2] / 2.0])
    x_cam = R_cw @ np.array([math.cos(brick.yaw_rad), math.sin(brick.yaw_rad), 0.0])
    return R_cw @ (top - T[:3, 3]), yaw_about_rad(x_cam), x_cam


def run_frames(n_frames: int, seed: int, hide_one: bool) -> tuple[np.ndarray, np.ndarray, int]:
    """2-D (world x-y) centre errors in metres, yaw errors in radians, and the number of bricks missed."""
    rng = np.random.default_rng(seed)
    errors, yaw_errors, missed = [], [], 0
    for _ in range(n_frames):
        T, bricks = random_view(rng, INTR, MARKERS, n_bricks=2)
        hidden = (
            frozenset(2 * b.brick_id + int(rng.integers(0, 2)) for b in bricks) if hide_one else frozenset()
        )
        image = render_frame(
            INTR,
            T,
            bricks,
            MARKERS,
            rng=rng,
            blur_sigma_px=float(rng.uniform(0.5, 1.0)),
            noise_sigma=2.0,
            hidden_markers=hidden,
        )
        found = {e.brick_id: e for e in estimate_bricks(image, INTR, MARKERS)}
        for b in bricks:
            est = found.get(b.brick_id)
            if est is None:
                missed += 1
                continue
            centre_w = T[:3, :3] @ est.center_m + T[:3, 3]
            top_w = np.asarray(b.position_m) + np.array([0.0, 0.0, b.size_m[2] / 2.0])
            errors.append(float(np.hypot(*(centre_w - top_w)[:2])))
            yaw_errors.append(abs(wrap(est.yaw_rad - truth_in_camera(T, b)[1])))
            assert est.tags == tuple(sorted({2 * b.brick_id, 2 * b.brick_id + 1} - hidden))
    return np.array(errors), np.array(yaw_errors), missed


def test_accuracy_with_both_markers() -> None:
    """Issue target over 200 frames: mean <= 0.5 cm and 0.5 deg (benchmarks/bench_accuracy.py measures it)."""
    err, yaw_err, missed = run_frames(24, seed=101, hide_one=False)
    assert missed == 0
    assert err.mean() < 0.001 and err.max() < 0.005  # metres
    assert math.degrees(yaw_err.mean()) < 0.2 and math.degrees(yaw_err.max()) < 1.0


def test_accuracy_with_one_marker_hidden() -> None:
    """Issue target: mean <= 1.5 cm and worst <= 3 cm (the gripper's tolerance) with one marker hidden."""
    err, yaw_err, missed = run_frames(24, seed=202, hide_one=True)
    assert missed == 0
    assert err.mean() < 0.003 and err.max() < 0.015
    assert math.degrees(yaw_err.mean()) < 0.5 and math.degrees(yaw_err.max()) < 3.0


def test_joint_fit_beats_per_marker_poses_with_the_paper_filter() -> None:
    """Fitting both markers' 8 corners jointly constrains depth better than two separate 5 cm squares."""
    from masonry.perception.estimation import EstimatorConfig, estimate_brick_pose

    rng = np.random.default_rng(7)
    joint, separate = [], []
    for _ in range(15):
        T, bricks = random_view(rng, INTR, MARKERS, n_bricks=2)
        image = render_frame(INTR, T, bricks, MARKERS, rng=rng, blur_sigma_px=0.8)
        tags = {t.marker_id: t for t in detect_tags(image, INTR, MARKERS)}
        fits = {e.brick_id: e for e in estimate_bricks(image, INTR, MARKERS)}
        for b in bricks:
            centre, _, _ = truth_in_camera(T, b)
            paper = estimate_brick_pose(
                tags[2 * b.brick_id], tags[2 * b.brick_id + 1], EstimatorConfig(spacing_m=MARKERS.spacing_m)
            )
            assert paper is not None
            joint.append(np.linalg.norm(fits[b.brick_id].center_m - centre))
            separate.append(np.linalg.norm(paper.center_m - centre))
    assert np.mean(joint) < np.mean(separate)
    assert np.mean(joint) < 0.002


def test_tag_poses_match_the_layout() -> None:
    rng = np.random.default_rng(17)
    T, bricks = random_view(rng, INTR, MARKERS, n_bricks=3)
    image = render_frame(INTR, T, bricks, MARKERS, rng=rng)
    tags = detect_tags(image, INTR, MARKERS)
    assert sorted(t.marker_id for t in tags) == sorted(2 * b.brick_id + k for b in bricks for k in (0, 1))
    for tag in tags:
        brick = next(b for b in bricks if b.brick_id == tag.marker_id // 2)
        centre, _, x_cam = truth_in_camera(T, brick)
        along = 0.5 if tag.marker_id % 2 == 0 else -0.5
        expected = centre + x_cam * along * MARKERS.spacing_m
        assert np.linalg.norm(tag.position_m - expected) < 0.01
        assert math.degrees(math.acos(np.clip(tag.R_cam_marker[:, 0] @ x_cam, -1, 1))) < 3.0
        assert tag.R_cam_marker[2, 2] < -0.95  # the printed face looks back at the camera
        assert np.allclose(tag.R_cam_marker.T @ tag.R_cam_marker, np.eye(3), atol=1e-9)


def test_estimates_under_lens_distortion() -> None:
    intr = CameraIntrinsics(600.0, 600.0, 319.5, 239.5, distortion=(-0.25, 0.08, 0.001, -0.001, 0.0))
    rng = np.random.default_rng(23)
    for _ in range(5):
        T, bricks = random_view(rng, intr, MARKERS, n_bricks=2)
        image = render_frame(intr, T, bricks, MARKERS, rng=rng)
        found = {e.brick_id: e for e in estimate_bricks(image, intr, MARKERS)}
        for b in bricks:
            centre, yaw, _ = truth_in_camera(T, b)
            assert np.linalg.norm(found[b.brick_id].center_m - centre) < 0.004
            assert abs(wrap(found[b.brick_id].yaw_rad - yaw)) < math.radians(1.0)


def test_up_sets_the_yaw_axis() -> None:
    from masonry.perception.estimation import EstimatorConfig

    rng = np.random.default_rng(29)
    T, bricks = random_view(rng, INTR, MARKERS, n_bricks=1)
    image = render_frame(INTR, T, bricks, MARKERS, rng=rng)
    down = estimate_bricks(image, INTR, MARKERS)[0]
    flipped = estimate_bricks(image, INTR, MARKERS, EstimatorConfig(up=(0.0, 0.0, -1.0)))[0]
    assert flipped.yaw_rad == pytest.approx(wrap(-down.yaw_rad), abs=1e-9)
    assert np.allclose(flipped.center_m, down.center_m)


def test_bgr_and_grey_give_the_same_answer() -> None:
    rng = np.random.default_rng(31)
    T, bricks = random_view(rng, INTR, MARKERS)
    grey = render_frame(INTR, T, bricks, MARKERS, rng=rng)
    a = estimate_bricks(grey, INTR, MARKERS)
    b = estimate_bricks(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR), INTR, MARKERS)
    assert [e.brick_id for e in a] == [e.brick_id for e in b] == sorted(x.brick_id for x in bricks)
    for x, y in zip(a, b):
        assert np.allclose(x.center_m, y.center_m) and x.yaw_rad == pytest.approx(y.yaw_rad)


def test_nothing_to_see() -> None:
    image = render_frame(INTR, look_down((0.0, 0.0, 1.3)), [], MARKERS, rng=0)
    assert detect_tags(image, INTR, MARKERS) == []
    assert estimate_bricks(image, INTR, MARKERS) == []


def test_a_duplicated_id_keeps_the_larger_marker() -> None:
    T = look_down((0.0, 0.0, 1.3))
    near = RenderedBrick(4, (0.25, 0.1, 0.35), 0.2)  # closer to the camera: drawn larger
    far = RenderedBrick(4, (-0.3, -0.2, 0.05), 0.2)
    image = render_frame(INTR, T, [near, far], MARKERS, rng=1)
    found = estimate_bricks(image, INTR, MARKERS)
    assert len(found) == 1
    centre_w = T[:3, :3] @ found[0].center_m + T[:3, 3]
    assert np.linalg.norm(centre_w - [0.25, 0.1, 0.40]) < 0.01


@pytest.mark.parametrize("name", ["DICT_4X4_51", "dict_4x4_50", "CORNER_REFINE_NONE", "", "DICT_"])
def test_unknown_dictionary(name: str) -> None:
    with pytest.raises(PerceptionError, match="unknown ArUco dictionary"):
        aruco_dictionary(name)
    image = np.zeros((48, 64), np.uint8)
    with pytest.raises(PerceptionError, match=repr(name).replace("[", r"\[")):
        estimate_bricks(image, INTR, MarkerSpec(dictionary=name))


@pytest.mark.parametrize(
    "image", [np.zeros((0, 0), np.uint8), np.zeros((4, 4, 4, 4), np.uint8), np.zeros((5, 5, 2))]
)
def test_not_an_image(image: np.ndarray) -> None:
    with pytest.raises(InputError, match="image"):
        detect_tags(image, INTR, MARKERS)


def test_layout_geometry() -> None:
    both = brick_corner_layout(MARKERS, (6, 7))
    assert both.shape == (8, 3)
    assert np.allclose(both[:4].mean(axis=0), [MARKERS.spacing_m / 2.0, 0.0, 0.0])
    assert np.allclose(both[4:].mean(axis=0), [-MARKERS.spacing_m / 2.0, 0.0, 0.0])
    assert np.allclose(both[0] - both[:4].mean(axis=0), [-0.025, 0.025, 0.0])  # TL: image top is +y


@given(
    st.tuples(*[st.floats(-1, 1) for _ in range(3)]).filter(lambda v: math.hypot(*v) > 0.1),
    st.tuples(*[st.floats(-1, 1) for _ in range(3)]).filter(lambda v: math.hypot(*v) > 0.1),
)
def test_yaw_convention_matches_the_estimation_math(
    direction: tuple[float, ...], up: tuple[float, ...]
) -> None:
    from masonry.perception import estimation

    a = yaw_about_rad(np.array(direction), np.array(up))
    b = estimation.yaw_about_rad(direction, up)
    assert abs(wrap(a - b)) < 1e-9 or math.hypot(*np.cross(direction, up)) < 1e-6


def test_yaw_about_z_is_atan2() -> None:
    assert yaw_about_rad(np.array([0.0, 1.0, 0.3])) == pytest.approx(math.pi / 2)
    assert yaw_about_rad(np.array([1.0, 1.0, 0.0]), (0.0, 0.0, -1.0)) == pytest.approx(-math.pi / 4)


def test_markers_of_two_bricks_with_one_id_are_not_fused() -> None:
    """Marker 2k of one brick and 2k+1 of another (same id printed twice) do not fit one layout: use one marker."""
    T = look_down((0.0, 0.0, 1.3))
    near = RenderedBrick(4, (0.25, 0.1, 0.35), 0.2)  # shows only marker 9
    far = RenderedBrick(4, (-0.3, -0.2, 0.05), -0.4)  # shows only marker 8 (drawn smaller)
    image = render_frame(INTR, T, [near, far], MARKERS, rng=1, hidden_markers=frozenset({8}))
    image_far = render_frame(INTR, T, [far], MARKERS, rng=1, hidden_markers=frozenset({9}))
    image = np.where(image_far < 60, image_far, image)  # far brick's marker 8 pasted in (its black cells)
    found = estimate_bricks(image, INTR, MARKERS)
    assert len(found) == 1
    centre_w = T[:3, :3] @ found[0].center_m + T[:3, 3]
    assert np.linalg.norm(centre_w - [0.25, 0.1, 0.40]) < 0.01  # the larger (nearer) marker's brick
    assert found[0].tags == (9,)
