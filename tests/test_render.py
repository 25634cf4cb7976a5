"""The synthetic camera: markers land exactly where the geometry puts them; frames are deterministic per seed."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from masonry.blueprint import MarkerSpec
from masonry.errors import PerceptionError
from masonry.perception.aruco import brick_corner_layout, detect_markers
from masonry.perception.render import RenderedBrick, look_down, random_view, render_frame
from masonry.perception.types import CameraIntrinsics

INTR = CameraIntrinsics(600.0, 600.0, 319.5, 239.5)
MARKERS = MarkerSpec()


def true_corners(
    T_world_cam: np.ndarray, brick: RenderedBrick, marker_id: int, intr: CameraIntrinsics
) -> np.ndarray:
    """Pixel corners (TL, TR, BR, BL) of one marker by projecting the layout (with the lens model)."""
    c, s = math.cos(brick.yaw_rad), math.sin(brick.yaw_rad)
    R_wb = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    top = np.asarray(brick.position_m) + np.array([0.0, 0.0, brick.size_m[2] / 2.0])
    pts_w = brick_corner_layout(MARKERS, (marker_id,)) @ R_wb.T + top
    R_cw = T_world_cam[:3, :3].T
    rvec = cv2.Rodrigues(R_cw)[0]
    tvec = -R_cw @ T_world_cam[:3, 3]
    return cv2.projectPoints(pts_w, rvec, tvec, intr.matrix(), intr.dist_coeffs())[0].reshape(4, 2)


def test_shape_dtype_and_determinism() -> None:
    T, bricks = random_view(np.random.default_rng(1), INTR, MARKERS)
    a = render_frame(INTR, T, bricks, MARKERS, rng=5)
    b = render_frame(INTR, T, bricks, MARKERS, rng=np.random.default_rng(5))
    c = render_frame(INTR, T, bricks, MARKERS, rng=6)
    assert a.shape == (480, 640) and a.dtype == np.uint8
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)  # fresh sensor noise
    assert 40 < float(a.mean()) < 200 and float(a.std()) > 15  # a lit, textured scene, not a blank frame


@pytest.mark.parametrize("seed", range(6))
def test_markers_are_drawn_where_the_geometry_puts_them(seed: int) -> None:
    """Without blur and noise the detected corners sit on the projected layout to a small fraction of a pixel."""
    rng = np.random.default_rng(seed)
    T, bricks = random_view(rng, INTR, MARKERS, n_bricks=2)
    image = render_frame(INTR, T, bricks, MARKERS, rng=rng, blur_sigma_px=0.0, noise_sigma=0.0)
    found = {m.marker_id: m.corners_px for m in detect_markers(image, MARKERS)}
    expected = {2 * b.brick_id + k: (b, 2 * b.brick_id + k) for b in bricks for k in (0, 1)}
    assert set(found) == set(expected)
    for marker_id, (brick, mid) in expected.items():
        err = np.linalg.norm(found[marker_id] - true_corners(T, brick, mid, INTR), axis=1)
        assert err.max() < 0.35, (marker_id, err)


def test_lens_distortion_is_rendered() -> None:
    intr = CameraIntrinsics(600.0, 600.0, 319.5, 239.5, distortion=(-0.25, 0.08, 0.001, -0.001, 0.0))
    rng = np.random.default_rng(11)
    T, bricks = random_view(rng, intr, MARKERS, n_bricks=2)
    image = render_frame(intr, T, bricks, MARKERS, rng=rng, blur_sigma_px=0.0, noise_sigma=0.0)
    found = {m.marker_id: m.corners_px for m in detect_markers(image, MARKERS, intr)}
    assert len(found) == 4
    for b in bricks:
        for mid in (2 * b.brick_id, 2 * b.brick_id + 1):
            distorted = true_corners(T, b, mid, intr)
            pinhole = true_corners(T, b, mid, INTR)
            err = np.linalg.norm(found[mid] - distorted, axis=1)
            assert err.max() < 0.5, err
            assert np.linalg.norm(distorted - pinhole, axis=1).max() > 1.0  # the lens really bent them


def test_hidden_markers_are_not_drawn() -> None:
    rng = np.random.default_rng(3)
    T, bricks = random_view(rng, INTR, MARKERS, n_bricks=2)
    hide = frozenset({2 * bricks[0].brick_id})
    image = render_frame(INTR, T, bricks, MARKERS, rng=rng, hidden_markers=hide)
    ids = {m.marker_id for m in detect_markers(image, MARKERS)}
    assert ids == {2 * b.brick_id + k for b in bricks for k in (0, 1)} - hide


def test_bricks_out_of_view_or_behind_the_camera() -> None:
    T = look_down((0.0, 0.0, 1.3))
    bricks = [
        RenderedBrick(0, (5.0, 0.0, 0.05), 0.0),  # far outside the field of view
        RenderedBrick(1, (0.0, 0.0, 1.5), 0.3),  # above the camera (behind it)
        RenderedBrick(2, (0.02, 0.0, 1.25), 0.0),  # straddling the near plane, right under the lens
    ]
    image = render_frame(INTR, T, bricks, MARKERS, rng=0)
    assert image.shape == (480, 640)
    assert detect_markers(image, MARKERS) == []


def test_shadow_darkens_the_ground() -> None:
    T = look_down((0.0, 0.0, 1.3))
    floating = [RenderedBrick(0, (0.0, 0.0, 0.40), 0.0)]
    lit = render_frame(INTR, T, [], MARKERS, rng=0, noise_sigma=0.0)
    shaded = render_frame(INTR, T, floating, MARKERS, rng=0, noise_sigma=0.0)
    # The sun is toward +x+y, so the shadow of a brick 0.35 m off the ground falls toward -x-y of it.
    shadow_w = np.array([-0.27, -0.13, 0.0])  # in the shadow, outside the (perspective-enlarged) brick
    R_cw = T[:3, :3].T
    p = INTR.matrix() @ (R_cw @ (shadow_w - T[:3, 3]))
    u, v = int(p[0] / p[2]), int(p[1] / p[2])
    assert float(shaded[v - 3 : v + 4, u - 3 : u + 4].mean()) < 0.7 * float(
        lit[v - 3 : v + 4, u - 3 : u + 4].mean()
    )


def test_look_down_points_the_optical_axis_down() -> None:
    T = look_down((1.0, 2.0, 3.0), yaw_rad=0.7)
    assert np.allclose(T[:3, 2], [0.0, 0.0, -1.0])
    assert np.allclose(T[:3, 0], [math.cos(0.7), math.sin(0.7), 0.0])
    tilted = look_down((0.0, 0.0, 1.0), tilt_rad=math.radians(4.0), tilt_azimuth_rad=1.0)
    assert math.degrees(math.acos(-tilted[2, 2])) == pytest.approx(4.0)
    assert np.allclose(tilted[:3, :3] @ tilted[:3, :3].T, np.eye(3))


def test_marker_outside_the_dictionary_is_a_clear_error() -> None:
    T = look_down((0.0, 0.0, 1.3))
    with pytest.raises(PerceptionError, match="marker id 60 is not in DICT_4X4_50"):
        render_frame(INTR, T, [RenderedBrick(30, (0.0, 0.0, 0.05), 0.0)], MARKERS, rng=0)


def test_bad_pose_shape() -> None:
    with pytest.raises(ValueError, match="4x4"):
        render_frame(INTR, np.eye(3), [], MARKERS, rng=0)


def test_perception_package_loads_opencv_lazily() -> None:
    import subprocess
    import sys

    code = (
        "import sys, masonry.perception as p; before = 'cv2' in sys.modules; "
        "names = [p.render_frame, p.RenderedBrick, p.estimate_bricks, p.detect_tags, p.read_calibration]; "
        "print(before, 'cv2' in sys.modules, all(callable(n) for n in names))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True", "True"]
