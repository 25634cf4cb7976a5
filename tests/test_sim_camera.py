"""The simulated camera agrees with the perception pipeline: marker conventions, estimation, rendering."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import Blueprint, Brick, MarkerSpec, UavSpec
from masonry.perception import EstimatorConfig, TagPose, estimate_brick_pose
from masonry.sim import CameraConfig, World
from masonry.sim.bricks import SimBrick
from masonry.sim.camera import R_world_body, observe_markers
from sim_helpers import fly_to, take_off


def to_world(tag: TagPose, T_wc: np.ndarray) -> TagPose:
    return TagPose(
        tag.marker_id, T_wc[:3, :3] @ tag.position_m + T_wc[:3, 3], T_wc[:3, :3] @ tag.R_cam_marker
    )


def one_brick_world(yaw_rad: float, seed: int = 0, camera: str = "geometric") -> World:
    bp = Blueprint(
        bricks=(Brick(0, (0.0, 0.0, 0.05), placed=True, yaw_rad=yaw_rad),),
        fleet=(UavSpec("brick-1", "brick", (-1.0, 0.0, 0.0)),),
    )
    w = World(bp, seed=seed, camera=camera)  # type: ignore[arg-type]
    w.add_fleet()
    return w


@settings(max_examples=12)
@given(st.floats(-math.pi, math.pi - 1e-6), st.integers(0, 1000))
def test_estimated_pose_from_simulated_tags_matches_the_true_brick(yaw: float, seed: int) -> None:
    w = one_brick_world(yaw, seed)
    uav = w.uavs["brick-1"]
    take_off(w, uav)
    fly_to(w, uav, (-0.1, 0.0, 1.2), tol_m=0.01)
    frame = uav.camera.read()
    assert frame is not None and frame.tags is not None
    T = w.camera_pose(uav)
    tags = {t.marker_id: to_world(t, T) for t in frame.tags}
    assert set(tags) == {0, 1}
    both = estimate_brick_pose(tags[0], tags[1], EstimatorConfig())
    assert both is not None
    assert np.allclose(both.center_m, (0.0, 0.0, 0.10), atol=0.02)
    assert abs(math.remainder(both.yaw_rad - yaw, math.tau)) < 0.1
    for single in (tags[0], tags[1]):  # one tag alone: its orientation carries the yaw
        est = estimate_brick_pose(single, None, EstimatorConfig())
        assert est is not None
        assert np.allclose(est.center_m, (0.0, 0.0, 0.10), atol=0.03)
        assert abs(math.remainder(est.yaw_rad - yaw, math.tau)) < 0.1


def test_rendered_frame_is_detected_where_the_geometric_camera_sees_the_markers() -> None:
    from masonry.perception.aruco import detect_tags

    w = one_brick_world(0.4, seed=3, camera="render")
    uav = w.uavs["brick-1"]
    take_off(w, uav)
    fly_to(w, uav, (-0.1, 0.0, 1.2), tol_m=0.01)
    frame = uav.camera.read()
    assert frame is not None and frame.image is not None
    tags = detect_tags(frame.image, uav.camera.intrinsics, w.blueprint.markers)
    T = w.camera_pose(uav)
    seen = {t.marker_id: to_world(t, T) for t in tags}
    assert set(seen) == {0, 1}
    est = estimate_brick_pose(seen[0], seen[1], EstimatorConfig())
    assert est is not None
    assert np.allclose(est.center_m, (0.0, 0.0, 0.10), atol=0.02)
    assert abs(math.remainder(est.yaw_rad - 0.4, math.tau)) < 0.05


def test_field_of_view_edges() -> None:
    """A marker is seen only with all four corners inside the image (the camera model, no world)."""
    cfg = CameraConfig()
    brick = SimBrick(0, Brick(0, (0.0, 0.0, 0.05)), (0.0, 0.0, 0.05), 0.0, "placed")
    R_wc = R_world_body(0.0, 0.0, 0.0) @ np.diag([1.0, -1.0, -1.0])  # looking straight down
    rng = np.random.default_rng(0)
    markers = MarkerSpec()
    height = 1.0
    half_width_m = (cfg.intrinsics.width_px / 2.0) / cfg.intrinsics.fx * (height - 0.10)
    # Marker 0 sits at x = +0.0875 with half size 0.025: its far edge at 0.1125 from the brick centre.
    edge = 0.0875 + 0.025
    inside = np.array([-(half_width_m - edge) + 0.01, 0.0, height])
    outside = np.array([-(half_width_m - edge) - 0.01, 0.0, height])
    ids_in = {t.marker_id for t in observe_markers(R_wc, inside, [brick], markers, cfg, rng)}
    ids_out = {t.marker_id for t in observe_markers(R_wc, outside, [brick], markers, cfg, rng)}
    assert 0 in ids_in and 0 not in ids_out and 1 in ids_out
    # Facing away: a camera below the markers' plane looking up sees nothing.
    R_up = np.diag([1.0, 1.0, 1.0])
    assert observe_markers(R_up, np.array([0.0, 0.0, -1.0]), [brick], markers, cfg, rng) == ()


def test_markers_under_a_brick_are_not_seen() -> None:
    bp = Blueprint(
        bricks=(
            Brick(0, (0.0, 0.0, 0.05), placed=True),
            Brick(1, (0.15, 0.0, 0.15), placed=True),  # covers brick 0's marker 0 (at x = +0.0875)
        ),
        fleet=(UavSpec("brick-1", "brick", (-1.0, 0.0, 0.0)),),
    )
    w = World(bp, seed=0)
    uav = w.add_fleet()[0]
    take_off(w, uav)
    fly_to(w, uav, (-0.05, 0.0, 1.2), tol_m=0.01)
    frame = uav.camera.read()
    assert frame is not None and frame.tags is not None
    assert {t.marker_id for t in frame.tags} == {1, 2, 3}
