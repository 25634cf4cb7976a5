"""Camera port on OpenCV ``VideoCapture``: a device index, a video file, or a GStreamer pipeline.

Frames come out as :class:`~masonry.ports.CameraFrame` with ``image`` set (BGR as captured) and a time stamp from
the injected clock, so they go through the same ArUco pipeline as the simulator's rendered frames. Intrinsics
come from the calibration file written by ``masonry calibrate`` (:func:`masonry.perception.calibration.read_calibration`).

Live sources (device, GStreamer) are read by a background thread that keeps only the newest frame: a controller
ticking at 20 Hz must not work on frames queued in the driver a second ago. Files are read in order, one frame
per ``read()``, so a recorded flight replays deterministically.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from typing_extensions import Self

from masonry.airframe import DEFAULT_AIRFRAME, Airframe
from masonry.errors import DeviceNotFound, InputError
from masonry.perception.types import CameraIntrinsics
from masonry.ports import CameraFrame, Clock


class _WallClock:
    def now_s(self) -> float:
        return time.monotonic()

    def sleep(self, duration_s: float) -> None:
        time.sleep(max(0.0, duration_s))


def parse_source(source: str | int) -> tuple[str, int | str]:
    """``"0"`` / ``0`` -> ("index", 0); a string with ``!`` -> ("gstreamer", pipeline); else ("file", path)."""
    if isinstance(source, int):
        return ("index", source)
    text = source.strip()
    if text.isdigit():
        return ("index", int(text))
    if "!" in text:
        return ("gstreamer", text)
    return ("file", text)


class OpenCvCamera:
    """The downward camera through OpenCV (construct, then ``connect``).

    Args:
        source: device index (``0``), video file path, or GStreamer pipeline ending in ``appsink``.
        intrinsics: the calibration (or give ``calibration``).
        calibration: path of a ``masonry calibrate`` FileStorage YAML.
        airframe: where the camera sits on the body (``T_body_cam``).
        clock: time stamps (default: the monotonic wall clock).
        threaded: grab in the background keeping the newest frame (default: True for live sources).
        check_size: refuse frames whose size differs from the calibration's (a calibration is per resolution).
    """

    def __init__(
        self,
        source: str | int,
        *,
        intrinsics: CameraIntrinsics | None = None,
        calibration: str | Path | None = None,
        airframe: Airframe = DEFAULT_AIRFRAME,
        clock: Clock | None = None,
        threaded: bool | None = None,
        check_size: bool = True,
    ) -> None:
        if intrinsics is None and calibration is None:
            raise InputError(
                "a camera needs its intrinsics: give `calibration` FILE (from `masonry calibrate`)",
                options=("calibration",),
            )
        self.source = source
        self.kind, self.target = parse_source(source)
        self._intrinsics = intrinsics
        self.calibration = calibration
        self.airframe = airframe
        self.clock: Clock = clock if clock is not None else _WallClock()
        self.threaded = self.kind != "file" if threaded is None else threaded
        self.check_size = check_size
        self.frames_read = 0
        self._capture: Any = None
        self._latest: CameraFrame | None = None
        self._fresh = False
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._size_checked = False

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def intrinsics(self) -> CameraIntrinsics:
        if self._intrinsics is None:
            from masonry.perception.calibration import read_calibration

            assert self.calibration is not None
            self._intrinsics = read_calibration(self.calibration)
        return self._intrinsics

    @property
    def T_body_cam(self) -> np.ndarray:
        return self.airframe.T_body_cam()

    @property
    def connected(self) -> bool:
        return self._capture is not None

    def connect(self) -> None:
        """Open the source (and read the calibration).

        Raises:
            InputError: the video file does not exist, or the calibration is unusable.
            DeviceNotFound: OpenCV cannot open the device, file or pipeline.
        """
        if self._capture is not None:
            return
        import cv2

        _ = self.intrinsics  # a bad calibration fails now, not in flight
        if self.kind == "file" and not Path(str(self.target)).is_file():
            raise InputError(
                f"{self.target}: video file not found (for a camera device give its index, e.g. 0)"
            )
        try:
            if self.kind == "gstreamer":
                capture = cv2.VideoCapture(str(self.target), cv2.CAP_GSTREAMER)
            else:
                capture = cv2.VideoCapture(self.target)
        except cv2.error as exc:
            raise DeviceNotFound(f"camera {self.source}: OpenCV cannot open it: {exc}") from exc
        if not capture.isOpened():
            capture.release()
            hint = {
                "index": "no such video device, or it is busy",
                "gstreamer": "this OpenCV build may lack GStreamer support, or the pipeline is invalid",
                "file": "not a video format OpenCV can decode",
            }[self.kind]
            raise DeviceNotFound(f"camera {self.source}: cannot open ({hint})")
        if self.kind == "index":
            intr = self.intrinsics
            capture.set(cv2.CAP_PROP_FRAME_WIDTH, intr.width_px)
            capture.set(cv2.CAP_PROP_FRAME_HEIGHT, intr.height_px)
        self._capture = capture
        if self.threaded:
            self._stop.clear()
            self._thread = threading.Thread(target=self._grab_loop, name="camera-grab", daemon=True)
            self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self._capture is not None:
            self._capture.release()
            self._capture = None

    def _grab(self) -> CameraFrame | None:
        ok, image = self._capture.read()
        if not ok or image is None:
            return None
        self.frames_read += 1
        return CameraFrame(time_s=self.clock.now_s(), image=image)

    def _grab_loop(self) -> None:
        while not self._stop.is_set():
            frame = self._grab()
            if frame is None:
                self._stop.wait(0.01)
                continue
            with self._lock:
                self._latest = frame
                self._fresh = True

    def _check(self, frame: CameraFrame) -> None:
        if self._size_checked or not self.check_size or frame.image is None:
            return
        h, w = frame.image.shape[:2]
        intr = self.intrinsics
        if (w, h) != (intr.width_px, intr.height_px):
            raise InputError(
                f"camera {self.source} gives {w}x{h} frames but the calibration is for "
                f"{intr.width_px}x{intr.height_px}: calibrate at the resolution you fly with"
            )
        self._size_checked = True

    def read(self) -> CameraFrame | None:
        """The newest frame not returned before, or None (no new frame yet; end of a file; not connected)."""
        if self._capture is None:
            return None
        if self.threaded:
            with self._lock:
                frame, fresh = self._latest, self._fresh
                self._fresh = False
            if not fresh or frame is None:
                return None
        else:
            frame = self._grab()
            if frame is None:
                return None
        self._check(frame)
        return frame
