"""OpenCV camera adapter: a recorded video of rendered bricks replays through the real ArUco pipeline."""

from __future__ import annotations

import json
import socket

import cv2
import numpy as np
import pytest

from masonry.adapters.camera import OpenCvCamera, parse_source
from masonry.adapters.pose_source import MocapPose, UdpPoseSource, parse_pose, quaternion_to_euler, send_pose
from masonry.blueprint import MarkerSpec
from masonry.errors import DeviceNotFound, InputError
from masonry.perception.aruco import detect_tags
from masonry.perception.calibration import write_calibration
from masonry.perception.render import RenderedBrick, look_down, render_frame
from masonry.perception.types import CameraIntrinsics
from masonry.ports import Camera
from waiting import wait_until

INTR = CameraIntrinsics(fx=500.0, fy=500.0, cx=319.5, cy=239.5, width_px=640, height_px=480)
MARKERS = MarkerSpec()


class StepClock:
    def __init__(self) -> None:
        self.t = 100.0

    def now_s(self) -> float:
        self.t += 0.1
        return self.t

    def sleep(self, duration_s: float) -> None:
        self.t += duration_s


@pytest.fixture()
def recording(tmp_path):
    """A 5-frame MJPG video of brick 3 seen from 1.0 m above its top, and its calibration file."""
    brick = RenderedBrick(3, (0.0, 0.0, 0.05), 0.3)
    path = tmp_path / "flight.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (640, 480))
    assert writer.isOpened()
    for i in range(5):
        grey = render_frame(INTR, look_down((0.02 * i, 0.0, 1.1)), [brick], MARKERS, rng=i)
        writer.write(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR))
    writer.release()
    calibration = tmp_path / "camera.yaml"
    write_calibration(calibration, INTR)
    return path, calibration


def test_a_video_file_goes_through_the_aruco_pipeline(recording) -> None:
    video, calibration = recording
    clock = StepClock()
    with OpenCvCamera(str(video), calibration=calibration, clock=clock) as cam:
        assert isinstance(cam, Camera)
        assert cam.intrinsics == INTR
        assert cam.T_body_cam.shape == (4, 4)
        frames = []
        while (frame := cam.read()) is not None:
            frames.append(frame)
    assert len(frames) == 5
    times = [f.time_s for f in frames]
    assert times == sorted(times) and times[0] > 100.0  # stamped by the injected clock
    for frame in frames:
        assert frame.image is not None and frame.image.shape == (480, 640, 3)
        tags = detect_tags(frame.image, INTR, MARKERS)
        assert sorted(t.marker_id for t in tags) == [6, 7]
        for tag in tags:
            assert tag.position_m[2] == pytest.approx(1.0, abs=0.03)  # 1.1 m camera, brick top at 0.1 m


def test_threaded_reading_returns_only_new_frames(recording) -> None:
    video, calibration = recording
    clock = StepClock()  # stamps 100.1, 100.2, ...: the fifth frame grabbed is the one stamped 100.5
    with OpenCvCamera(str(video), calibration=calibration, threaded=True, clock=clock) as cam:
        seen = []

        def last_frame_seen() -> bool:
            frame = cam.read()
            if frame is not None:
                seen.append(frame)
            return bool(seen) and seen[-1].time_s == pytest.approx(100.5)

        wait_until(last_frame_seen, 10.0, "the video's last frame")
        assert cam.frames_read == 5
        assert cam.read() is None  # nothing new after the end: the grabber holds no frame not returned
    assert 1 <= len(seen) <= 5
    assert len({id(f) for f in seen}) == len(seen)
    times = [f.time_s for f in seen]
    assert times == sorted(times)  # newest only, never an older one again


def test_resolution_must_match_the_calibration(recording, tmp_path) -> None:
    video, _ = recording
    other = tmp_path / "hd.yaml"
    write_calibration(other, CameraIntrinsics(900.0, 900.0, 639.5, 359.5, width_px=1280, height_px=720))
    with (
        OpenCvCamera(str(video), calibration=other) as cam,
        pytest.raises(InputError, match="640x480 frames but the calibration is for 1280x720"),
    ):
        cam.read()


def test_missing_inputs_are_clear_errors(tmp_path, recording) -> None:
    _, calibration = recording
    from masonry.cli.app import cli_message

    with pytest.raises(InputError, match="give `calibration` FILE") as info:
        OpenCvCamera(0)
    assert "give --calibration FILE" in cli_message(info.value)  # the CLI names its flag
    with pytest.raises(InputError, match=r"nothing\.mp4: video file not found"):
        OpenCvCamera(str(tmp_path / "nothing.mp4"), calibration=calibration).connect()
    with pytest.raises(InputError, match="calibration file not found"):
        OpenCvCamera(0, calibration=tmp_path / "none.yaml").connect()
    junk = tmp_path / "junk.avi"
    junk.write_bytes(b"this is not a video")
    with pytest.raises(DeviceNotFound, match=r"junk\.avi: cannot open"):
        OpenCvCamera(str(junk), calibration=calibration).connect()
    with pytest.raises(DeviceNotFound, match="camera 63: cannot open"):
        OpenCvCamera(63, calibration=calibration).connect()


def test_source_kinds() -> None:
    assert parse_source("0") == ("index", 0)
    assert parse_source(2) == ("index", 2)
    assert parse_source("v4l2src device=/dev/video0 ! videoconvert ! appsink")[0] == "gstreamer"
    assert parse_source("/data/flight.mp4") == ("file", "/data/flight.mp4")


def test_udp_pose_source_keeps_the_newest_pose_of_its_body() -> None:
    with (
        UdpPoseSource(0, body="brick-1", max_age_s=0.5) as source,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx,
    ):
        address = ("127.0.0.1", source.port)
        assert source.latest() is None
        send_pose(tx, address, MocapPose("brick-2", 1.0, (9.0, 9.0, 9.0), (0.0, 0.0, 0.0)))
        send_pose(tx, address, MocapPose("brick-1", 1.0, (1.0, 2.0, 0.5), (0.0, 0.0, 0.3)))
        tx.sendto(b"{not json", address)
        tx.sendto(json.dumps({"body": "brick-1", "position_m": [1, 2]}).encode(), address)
        wait_until(lambda: source.received >= 1 and source.rejected >= 2, 5.0, "the four datagrams")
        pose = source.latest()
        assert pose == MocapPose("brick-1", 1.0, (1.0, 2.0, 0.5), (0.0, 0.0, 0.3))
        assert source.rejected == 2 and "position_m must be a list of 3 numbers" in (source.last_error or "")


def test_pose_parsing() -> None:
    pose = parse_pose(
        b'{"position_m": [0, 0, 1], "quaternion": [0.7071068, 0, 0, 0.7071068]}', received_s=5.0
    )
    assert pose.time_s == 5.0 and pose.attitude_rad == pytest.approx((0.0, 0.0, np.pi / 2))
    assert quaternion_to_euler(1, 0, 0, 0) == (0.0, 0.0, 0.0)
    with pytest.raises(InputError, match="time_s"):
        parse_pose(b'{"position_m": [0, 0, 1], "time_s": "now"}', received_s=0.0)
    with pytest.raises(InputError, match="finite"):
        parse_pose(b'{"position_m": [0, NaN, 1]}', received_s=0.0)


def test_a_real_camera_in_the_pre_flight_check(recording, tmp_path) -> None:
    from pathlib import Path

    from masonry.adapters.wiring import HardwareConfig, open_adapters, preflight
    from masonry.blueprint import load_blueprint

    video, calibration = recording
    bp = load_blueprint(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
    spec = bp.uavs("brick")[0]
    hw = HardwareConfig(camera=str(video), calibration=str(calibration))
    opened = open_adapters(hw, blueprint=bp, spec=spec)
    try:
        report = preflight(opened, hw)
        assert isinstance(opened.camera, OpenCvCamera) and opened.camera.clock is opened.clock
    finally:
        opened.close()
    assert report.ok
    assert any(
        line.startswith("  [ok  ] camera: OpenCV file") and "640x480 frames" in line
        for line in report.lines()
    )
    other = tmp_path / "hd.yaml"
    write_calibration(other, CameraIntrinsics(900.0, 900.0, 639.5, 359.5, width_px=1280, height_px=720))
    hw = HardwareConfig(camera=str(video), calibration=str(other))
    opened = open_adapters(hw, blueprint=bp, spec=spec)
    try:
        report = preflight(opened, hw)
    finally:
        opened.close()
    assert not report.ok and "calibration is for 1280x720" in report.reasons[0]
