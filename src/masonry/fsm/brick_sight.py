"""The brick UAV's camera on the brick of its task: found by its marker ids *and* where it is expected (issue 30).

A big wall reuses marker numbers (:mod:`masonry.marker_reuse`): two bricks may carry the same ArUco ids when no
camera pose can see both, so their sites are more than the camera's co-visible span apart. A marker with the task's
ids counts only when it lies within :func:`~masonry.marker_reuse.identify_radius_m` (half that span) of where the
brick is expected -- its pickup -- so the other brick with the same ids, wherever it is, is never taken for it.
On a wall that reuses nothing the test never fails: a brick lies centimetres from its pickup, not metres.
"""

from __future__ import annotations

import math

import numpy as np

from masonry.blueprint import MarkerSpec
from masonry.fsm.as_built import frame_tags
from masonry.geometry import R_world_body
from masonry.perception.estimation import EstimatorConfig, estimate_brick_pose
from masonry.perception.types import TagPose
from masonry.planner.tasks import BrickTask
from masonry.ports import Camera, Telemetry

__all__ = ["expected_top_m", "sight_brick"]


def expected_top_m(task: BrickTask) -> tuple[float, float, float]:
    """Where the task's brick is expected while it waits: the top-face centre at its pickup."""
    assert task.pickup_m is not None
    x, y, z = task.pickup_m
    return (x, y, z + task.size_m[2] / 2.0)


def sight_brick(
    camera: Camera,
    T_body_cam: np.ndarray,
    tel: Telemetry,
    task: BrickTask,
    markers: MarkerSpec,
    est_config: EstimatorConfig,
    radius_m: float,
) -> tuple[np.ndarray, float] | None:
    """The task's brick's top-face centre (world, m) and yaw as the camera sees it now, from ``tel``'s pose.

    None when the camera has no frame, or sees none of the brick's markers within ``radius_m`` of its pickup.
    """
    tags = frame_tags(camera.read(), camera, markers)
    id1, id2 = task.marker_ids
    mine = [tag for tag in tags if tag.marker_id in (id1, id2)]
    if not mine:
        return None
    roll, pitch, yaw = tel.attitude_rad
    R_wb = R_world_body(roll, pitch, yaw)
    R_wc = R_wb @ T_body_cam[:3, :3]
    t_wc = np.asarray(tel.position_m, dtype=float) + R_wb @ T_body_cam[:3, 3]
    expected = expected_top_m(task)
    tag1 = tag2 = None
    for tag in mine:
        world = TagPose(tag.marker_id, R_wc @ np.asarray(tag.position_m) + t_wc, R_wc @ tag.R_cam_marker)
        if math.dist(world.position_m.tolist(), expected) > radius_m:
            continue  # the same ids on another brick, far from this one's pickup (a reused marker number)
        if tag.marker_id == id1:
            tag1 = world
        else:
            tag2 = world
    if tag1 is None and tag2 is None:
        return None
    est = estimate_brick_pose(tag1, tag2, est_config)
    return None if est is None else (np.asarray(est.center_m, dtype=float), float(est.yaw_rad))
