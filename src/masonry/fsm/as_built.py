"""The as-built look (issue 30): after each release the brick UAV estimates the pose of the brick it placed.

The brick is under the camera as the UAV climbs out of the placement (``place_ascend``): every frame that shows
one of its two markers gives an estimate (the paper's filter, :func:`~masonry.perception.estimation.estimate_brick_pose`,
on the marker poses turned into the world frame with the telemetry of that tick), and the first
``window_size`` of them (the nearest: the climb only takes the camera farther) fill a
:class:`~masonry.perception.estimation.PoseWindow`. At the end of the climb the window's mean is the brick's
as-built pose and its confidence the paper's C; the pose's distance from the designed centre is its deviation.
The climb is not lengthened: a UAV that saw nothing reports no as-built pose (the report says so).

The same frames give the pose relative to the wall (:mod:`masonry.fsm.relative_look`): the bricks of
``UavConfig.wall`` seen with the placed brick, placed in the world by the same telemetry, whose offsets from it
hold no position error; the pose's ``relative_*`` fields (``relative_offsets``: the offset from every neighbour
seen, with its frames).

A simulated camera draws the noise of these frames from a stream of their own (:class:`LooksBack`), so that
looking leaves every other random draw of a simulation, and so every pinned schedule, as it was.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from masonry.fsm.relative_look import RelativeLook
from masonry.geometry import R_world_body
from masonry.perception.estimation import EstimatorConfig, PoseWindow, estimate_brick_pose
from masonry.perception.types import AsBuiltPose, TagPose

if TYPE_CHECKING:
    from masonry.blueprint import MarkerSpec
    from masonry.planner.tasks import BrickTask
    from masonry.ports import Camera, CameraFrame, Telemetry

__all__ = ["AsBuiltLook", "LooksBack", "frame_tags", "touches", "world_estimate"]


@runtime_checkable
class LooksBack(Protocol):
    """A camera with a frame of its own for the as-built look (the simulated one: its own noise stream)."""

    def read_as_built(self) -> CameraFrame | None: ...


def frame_tags(frame: CameraFrame | None, camera: Camera, markers: MarkerSpec) -> Sequence[TagPose]:
    """The marker poses of a frame: the ones it carries, or those ArUco detects on its image."""
    if frame is None:
        return ()
    if frame.tags is not None:
        return frame.tags
    if frame.image is None:
        return ()
    from masonry.perception.aruco import detect_tags  # (OpenCV loads only for a rendered camera)

    return tuple(detect_tags(frame.image, camera.intrinsics, markers))


def world_estimate(
    tags: Sequence[TagPose],
    brick_id: int,
    tel: Telemetry,
    T_body_cam: np.ndarray,
    config: EstimatorConfig,
) -> tuple[np.ndarray, float] | None:
    """Brick ``brick_id``'s top-face centre (world, m) and yaw from its markers among ``tags`` (camera frame),
    the camera placed by ``tel``'s pose; None when neither of its markers is among them."""
    id1, id2 = 2 * brick_id, 2 * brick_id + 1
    tag1 = tag2 = None
    for tag in tags:
        if tag.marker_id == id1:
            tag1 = tag
        elif tag.marker_id == id2:
            tag2 = tag
    if tag1 is None and tag2 is None:
        return None
    R_wb = R_world_body(*tel.attitude_rad)
    R_wc = R_wb @ T_body_cam[:3, :3]
    t_wc = np.asarray(tel.position_m, dtype=float) + R_wb @ T_body_cam[:3, 3]

    def to_world(tag: TagPose | None) -> TagPose | None:
        if tag is None:
            return None
        return TagPose(tag.marker_id, R_wc @ np.asarray(tag.position_m) + t_wc, R_wc @ tag.R_cam_marker)

    est = estimate_brick_pose(to_world(tag1), to_world(tag2), config)
    return None if est is None else (np.asarray(est.center_m, dtype=float), float(est.yaw_rad))


def touches(own_top_m: np.ndarray, other_top_m: np.ndarray, size_m: tuple[float, float, float]) -> bool:
    """Designed top-face centres of two bricks of size ``size_m``: the other is the brick's course neighbour (centres
    within a brick length in the same course) or under it (one course below, overlapping): a brick it touches."""
    h = math.hypot(float(own_top_m[0] - other_top_m[0]), float(own_top_m[1] - other_top_m[1]))
    dz = float(own_top_m[2] - other_top_m[2])
    same = abs(dz) < 1e-6 and h <= size_m[0] * 1.01
    below = abs(dz - size_m[2]) < 1e-3 and h < size_m[0] * 0.99
    return same or below


class AsBuiltLook:
    """The estimates of one placed brick gathered during the climb out of its placement.

    Args:
        window_size: estimates kept (the first ones: the nearest).
        sigma_tol_m: the confidence's tolerance (the paper's sigma_tol).
    """

    def __init__(self, window_size: int, sigma_tol_m: float) -> None:
        self.window = PoseWindow(size=window_size, sigma_tol_m=sigma_tol_m)
        self.relative = RelativeLook(window_size, sigma_tol_m)
        self._wall: tuple[tuple[int, tuple[float, ...]], ...] = ()

    def begin(self) -> None:
        """A new placement: forget the last brick's estimates."""
        self.window.clear()
        self.relative.begin()

    def look(
        self,
        camera: Camera,
        brick_id: int,
        tel: Telemetry,
        markers: MarkerSpec,
        T_body_cam: np.ndarray,
        config: EstimatorConfig,
        wall: tuple[tuple[int, tuple[float, ...]], ...] = (),
    ) -> None:
        """One frame: its estimate of brick ``brick_id`` joins the window until the window is full, and its offsets
        from the bricks of ``wall`` (``UavConfig.wall``) in the same frame join theirs."""
        if self.window.count >= self.window.size:
            return
        frame = camera.read_as_built() if isinstance(camera, LooksBack) else camera.read()
        tags = frame_tags(frame, camera, markers)
        est = world_estimate(tags, brick_id, tel, T_body_cam, config)
        if est is None:
            return
        self.window.add(est[0], est[1])
        self._wall = wall
        designs = self.relative.wall(wall)
        seen = {}
        for bid in {t.marker_id // 2 for t in tags} - {brick_id}:
            if bid in designs and (other := world_estimate(tags, bid, tel, T_body_cam, config)) is not None:
                seen[bid] = other[0]
        self.relative.add(brick_id, est[0], seen, designs)

    def pose(self, task: BrickTask) -> AsBuiltPose | None:
        """The brick's as-built pose (its centre: the top face's less half its height) and deviation from the
        design; None with fewer than two estimates (no confidence)."""
        confidence = self.window.confidence()
        if confidence is None:
            return None
        top, yaw = self.window.mean()
        centre = (float(top[0]), float(top[1]), float(top[2]) - task.size_m[2] / 2.0)
        pose = AsBuiltPose(centre, float(yaw), math.dist(centre, task.position_m), float(confidence))
        designs = self.relative.wall(self._wall)
        rel = self.relative.pose(task.marker_ids[0] // 2, designs)
        if rel is None:
            return pose
        return replace(
            pose,
            relative_to=rel.relative_to,
            relative_offset_m=rel.offset_m,
            relative_deviation_m=rel.deviation_m,
            relative_offsets=tuple(
                (r.relative_to, r.offset_m, r.frames)
                for r in self.relative.poses(task.marker_ids[0] // 2, designs)
            ),
        )

    def neighbour_deviation_m(self, task: BrickTask) -> float | None:
        """How far the placed brick is from its designed offsets to the bricks it touches that were seen with it
        (the mean of its offset deviations from each: its own error less theirs, the wall's error cancelled);
        None when none of them was seen in two frames with it."""
        own = task.marker_ids[0] // 2
        designs = self.relative.wall(self._wall)
        own_design = designs.get(own)
        if own_design is None:
            return None
        devs = [
            np.asarray(r.offset_m) - (own_design - designs[r.relative_to])
            for r in self.relative.poses(own, designs)
            if touches(own_design, designs[r.relative_to], task.size_m)
        ]
        return float(np.linalg.norm(np.mean(devs, axis=0))) if devs else None
