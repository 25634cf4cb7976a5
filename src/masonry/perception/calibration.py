"""Camera calibration: OpenCV FileStorage YAML files <-> CameraIntrinsics, and chessboard calibration.

The file format is the one OpenCV's own calibration tools write (OpenCV 5 heads it ``%YAML 1.2``, 4.x
``%YAML:1.0``; both read back)::

    image_width: 640
    image_height: 480
    camera_matrix: !!opencv-matrix {rows: 3, cols: 3, dt: d, data: [fx, 0, cx, 0, fy, cy, 0, 0, 1]}
    distortion_coefficients: !!opencv-matrix {rows: 1, cols: 5, dt: d, data: [k1, k2, p1, p2, k3]}
    avg_reprojection_error: 0.21

Reading also accepts the key spellings ``cameraMatrix``/``K`` and ``dist_coeffs``/``distCoeffs``/``D``.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from masonry.errors import InputError
from masonry.perception.types import CameraIntrinsics

__all__ = [
    "CalibrationResult",
    "ChessboardSpec",
    "calibrate_chessboard",
    "find_chessboard",
    "parse_board",
    "read_calibration",
    "write_calibration",
]

_MATRIX_KEYS = ("camera_matrix", "cameraMatrix", "K")
_DIST_KEYS = ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D")


@dataclass(frozen=True)
class ChessboardSpec:
    """A chessboard target: inner corners per row (``cols``) and per column (``rows``), square side in metres."""

    cols: int
    rows: int
    square_m: float

    def object_points(self) -> np.ndarray:
        """Inner corners on the board plane (z = 0), row by row, shape (cols * rows, 3), metres."""
        grid = np.mgrid[0 : self.cols, 0 : self.rows].T.reshape(-1, 2)
        pts = np.zeros((self.cols * self.rows, 3), np.float32)
        pts[:, :2] = grid * self.square_m
        return pts


@dataclass(frozen=True)
class CalibrationResult:
    """Outcome of a calibration: the intrinsics, the RMS reprojection error (pixels) and which images served."""

    intrinsics: CameraIntrinsics
    rms_px: float
    used: tuple[str, ...]
    rejected: tuple[str, ...]


def parse_board(text: str) -> ChessboardSpec:
    """Parse ``chessboard:COLSxROWS:SQUARE_M`` (inner corners, square side in metres), e.g. ``chessboard:9x6:0.025``.

    Raises:
        InputError: the text is not of that form, or a number is out of range.
    """
    m = re.fullmatch(r"\s*chessboard:(\d+)[xX](\d+):([0-9]*\.?[0-9]+(?:[eE][-+]?\d+)?)\s*", text)
    if m is None:
        raise InputError(
            f"`board`: expected chessboard:COLSxROWS:SQUARE_M (inner corners, metres), e.g. chessboard:9x6:0.025; "
            f"got {text!r}",
            options=("board",),
        )
    cols, rows, square = int(m.group(1)), int(m.group(2)), float(m.group(3))
    if cols < 3 or rows < 3:
        raise InputError(
            f"`board`: a chessboard needs at least 3x3 inner corners, got {cols}x{rows}", options=("board",)
        )
    if cols > 100 or rows > 100:
        raise InputError(f"`board`: at most 100x100 inner corners, got {cols}x{rows}", options=("board",))
    if not 0.0 < square < 1.0:
        raise InputError(f"`board`: square side {square} m is out of range (0, 1) m", options=("board",))
    return ChessboardSpec(cols, rows, square)


def _read_matrix(fs: cv2.FileStorage, keys: Sequence[str]) -> np.ndarray | None:
    for key in keys:
        node = fs.getNode(key)
        if not node.empty():
            mat = node.mat()
            if mat is None:
                raise InputError(f"{key} is not an OpenCV matrix")
            return np.asarray(mat, dtype=float)
    return None


def read_calibration(path: str | Path) -> CameraIntrinsics:
    """Read a camera calibration from an OpenCV FileStorage file (YAML, or XML/JSON by extension).

    Raises:
        InputError: the file is missing, unreadable, or lacks a valid 3x3 camera matrix.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: calibration file not found")
    try:
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
    except cv2.error as exc:
        raise InputError(f"{p}: not an OpenCV FileStorage calibration file ({_cv_reason(exc)})") from exc
    if not fs.isOpened():
        raise InputError(f"{p}: cannot open as an OpenCV FileStorage calibration file")
    try:
        try:
            K = _read_matrix(fs, _MATRIX_KEYS)
            dist = _read_matrix(fs, _DIST_KEYS)
        except InputError as exc:
            raise InputError(f"{p}: {exc}") from exc
        width = fs.getNode("image_width")
        height = fs.getNode("image_height")
        w = int(width.real()) if not width.empty() else 0
        h = int(height.real()) if not height.empty() else 0
    finally:
        fs.release()
    if K is None:
        raise InputError(f"{p}: no camera_matrix (3x3) in the file")
    if K.shape != (3, 3) or not np.all(np.isfinite(K)) or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise InputError(f"{p}: camera_matrix must be a finite 3x3 matrix with fx, fy > 0")
    coeffs: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)
    if dist is not None:
        flat = dist.ravel()
        if flat.size not in (4, 5, 8, 12, 14) or not np.all(np.isfinite(flat)):
            raise InputError(f"{p}: distortion_coefficients must hold 4, 5, 8, 12 or 14 finite numbers")
        coeffs = tuple(float(x) for x in flat)
    return CameraIntrinsics(
        float(K[0, 0]),
        float(K[1, 1]),
        float(K[0, 2]),
        float(K[1, 2]),
        distortion=coeffs,
        width_px=w if w > 0 else 2 * math.floor(K[0, 2] + 0.5),
        height_px=h if h > 0 else 2 * math.floor(K[1, 2] + 0.5),
    )


def write_calibration(
    path: str | Path,
    intrinsics: CameraIntrinsics,
    *,
    rms_px: float | None = None,
    image_count: int | None = None,
) -> None:
    """Write ``intrinsics`` as an OpenCV FileStorage file (the format :func:`read_calibration` reads).

    Raises:
        InputError: the file cannot be written.
    """
    p = Path(path)
    try:
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
    except cv2.error as exc:
        raise InputError(f"{p}: cannot write calibration ({_cv_reason(exc)})") from exc
    if not fs.isOpened():
        raise InputError(f"{p}: cannot write calibration file")
    try:
        fs.write("calibration_time", time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
        fs.write("image_width", int(intrinsics.width_px))
        fs.write("image_height", int(intrinsics.height_px))
        fs.write("camera_matrix", intrinsics.matrix())
        fs.write("distortion_coefficients", np.asarray(intrinsics.distortion, dtype=float).reshape(1, -1))
        if rms_px is not None:
            fs.write("avg_reprojection_error", float(rms_px))
        if image_count is not None:
            fs.write("nr_of_frames", int(image_count))
    finally:
        fs.release()


def _cv_reason(exc: cv2.error) -> str:
    text = str(exc).strip().splitlines()
    return text[-1].strip() if text else "OpenCV error"


def find_chessboard(grey: np.ndarray, board: ChessboardSpec) -> np.ndarray | None:
    """Inner corners of ``board`` in a grey image, row by row, shape (n, 2) pixels, or None if not found."""
    found, corners = cv2.findChessboardCornersSB(
        grey, (board.cols, board.rows), flags=cv2.CALIB_CB_EXHAUSTIVE
    )
    if not found:
        found, corners = cv2.findChessboardCorners(
            grey, (board.cols, board.rows), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
        )
        if not found:
            return None
        corners = cv2.cornerSubPix(
            grey, corners, (5, 5), (-1, -1), (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.001)
        )
    return np.asarray(corners, dtype=np.float32).reshape(-1, 2)


def calibrate_chessboard(
    images: Sequence[tuple[str, np.ndarray]], board: ChessboardSpec, *, min_views: int = 3
) -> CalibrationResult:
    """Calibrate a pinhole camera with k1, k2, p1, p2, k3 distortion from named grey views of a chessboard.

    Raises:
        InputError: images of different sizes, or fewer than ``min_views`` views show the whole board.
    """
    if not images:
        raise InputError("no calibration images given")
    size = images[0][1].shape[:2]
    obj_pts, img_pts, used, rejected = [], [], [], []
    for name, grey in images:
        if grey.shape[:2] != size:
            raise InputError(
                f"{name}: image is {grey.shape[1]}x{grey.shape[0]} but {images[0][0]} is {size[1]}x{size[0]}; "
                "calibrate one camera mode at a time"
            )
        corners = find_chessboard(grey, board)
        if corners is None:
            rejected.append(name)
            continue
        obj_pts.append(board.object_points())
        img_pts.append(corners.reshape(-1, 1, 2))
        used.append(name)
    if len(used) < min_views:
        raise InputError(
            f"the {board.cols}x{board.rows} chessboard was found in {len(used)} of {len(images)} images; "
            f"need at least {min_views} (check the board size: inner corners, not squares)"
        )
    h, w = size
    rms, K, dist, _rvecs, _tvecs = cv2.calibrateCamera(obj_pts, img_pts, (w, h), None, None)
    if not math.isfinite(rms):
        raise InputError("calibration did not converge; use more views with the board at varied angles")
    intr = CameraIntrinsics(
        float(K[0, 0]),
        float(K[1, 1]),
        float(K[0, 2]),
        float(K[1, 2]),
        distortion=tuple(float(x) for x in np.asarray(dist).ravel()[:5]),
        width_px=int(w),
        height_px=int(h),
    )
    return CalibrationResult(intr, float(rms), tuple(used), tuple(rejected))
