"""One Camera contract, run against the scripted fake, the simulator's camera (geometric and rendered) and the OpenCV
adapter on a recorded video (synthetic frames of a rendered brick, written here).

What every Camera must do: report its intrinsics and a rigid mounting, return frames (or None: no new frame)
stamped by its clock in order, with an image of the calibrated size or marker poses, and show the markers of a
brick it looks down on. Time passes by the rig's ``advance`` (the fake's clock, the world's step; a video file
gives its next frame on every read).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import pytest

from masonry.blueprint import MarkerSpec
from masonry.perception.types import CameraIntrinsics
from masonry.ports import Camera, CameraFrame

MARKERS = MarkerSpec()


@dataclass
class Rig:
    camera: Camera
    advance: Callable[[], None]  # let a frame period pass
    markers_in_view: frozenset[int]  # the markers of the brick the camera looks down on


def _fake_rig() -> Iterator[Rig]:
    from masonry.fakes import FakeBrick, FakeCamera, FakeClock, FakeFlightController

    clock = FakeClock()
    fc = FakeFlightController(clock, position_m=(0.0, 0.0, 1.1))
    camera = FakeCamera(fc, [FakeBrick(3, (0.0, 0.0, 0.1))], markers=MARKERS)
    yield Rig(camera, lambda: clock.advance(0.1), frozenset({6, 7}))


def _sim_rig(mode: str) -> Iterator[Rig]:
    from masonry.sim import World
    from sim_helpers import fly_to, hover, take_off
    from test_sim_world import blueprint

    w = World(blueprint(), seed=1, camera=mode)  # type: ignore[arg-type]
    w.add_fleet()
    uav = w.uavs["brick-1"]
    take_off(w, uav)
    x, y, _ = w.bricks[0].top_center_m  # a placed brick (markers 0 and 1)
    dx, dy, _ = w.airframe.camera_offset_m
    assert fly_to(w, uav, (x - dx, y - dy, 1.1), tol_m=0.01, target_yaw_rad=0.0)
    yield Rig(uav.camera, lambda: hover(w, uav, 0.1), frozenset({0, 1}))


def _opencv_rig(tmp_path) -> Iterator[Rig]:
    import cv2

    from masonry.adapters.camera import OpenCvCamera
    from masonry.fakes import FakeClock
    from masonry.perception.render import RenderedBrick, look_down, render_frame

    intrinsics = CameraIntrinsics(fx=500.0, fy=500.0, cx=319.5, cy=239.5, width_px=640, height_px=480)
    path = tmp_path / "flight.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (640, 480))
    assert writer.isOpened()
    for i in range(6):
        grey = render_frame(intrinsics, look_down((0.02 * i, 0.0, 1.1)), [RenderedBrick(3, (0.0, 0.0, 0.05), 0.3)],
                            MARKERS, rng=i)  # fmt: skip
        writer.write(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))
    writer.release()
    clock = FakeClock(100.0)
    with OpenCvCamera(str(path), intrinsics=intrinsics, clock=clock, threaded=False) as camera:
        yield Rig(camera, lambda: clock.advance(0.1), frozenset({6, 7}))


@pytest.fixture(params=["fake", "sim-geometric", "sim-render", "opencv-file"])
def rig(request, tmp_path) -> Iterator[Rig]:
    if request.param == "fake":
        yield from _fake_rig()
    elif request.param.startswith("sim-"):
        yield from _sim_rig(request.param.removeprefix("sim-"))
    else:
        yield from _opencv_rig(tmp_path)


def _next_frame(rig: Rig) -> CameraFrame:
    for _ in range(5):  # a bounded number of frame periods
        rig.advance()
        frame = rig.camera.read()
        if frame is not None:
            return frame
    raise AssertionError("no frame within 5 frame periods")


def _markers(rig: Rig, frame: CameraFrame) -> set[int]:
    if frame.tags is not None:
        return {t.marker_id for t in frame.tags}
    from masonry.perception.aruco import detect_tags

    assert frame.image is not None
    return {t.marker_id for t in detect_tags(frame.image, rig.camera.intrinsics, MARKERS)}


def test_intrinsics_and_a_rigid_mounting(rig: Rig) -> None:
    cam = rig.camera
    assert isinstance(cam, Camera)
    k = cam.intrinsics
    assert isinstance(k, CameraIntrinsics)
    assert k.fx > 0 and k.fy > 0 and 0 < k.cx < k.width_px and 0 < k.cy < k.height_px
    T = np.asarray(cam.T_body_cam)
    assert T.shape == (4, 4) and np.allclose(T[3], (0.0, 0.0, 0.0, 1.0))
    R = T[:3, :3]
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.linalg.det(R) == pytest.approx(1.0)


def test_frames_are_stamped_in_order_with_an_image_of_the_calibrated_size_or_poses(rig: Rig) -> None:
    frames = [_next_frame(rig) for _ in range(3)]
    times = [f.time_s for f in frames]
    assert all(math.isfinite(t) for t in times) and times == sorted(times)
    k = rig.camera.intrinsics
    for frame in frames:
        assert frame.image is not None or frame.tags is not None
        if frame.image is not None:
            assert frame.image.shape[:2] == (k.height_px, k.width_px)


def test_a_brick_below_shows_its_markers(rig: Rig) -> None:
    frame = _next_frame(rig)
    assert set(rig.markers_in_view) <= _markers(rig, frame)
