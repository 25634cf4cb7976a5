"""ArUco markers on images: detection, marker poses, and the joint pose fit of each brick (camera frame).

Detection uses OpenCV's ``ArucoDetector`` (OpenCV >= 4.7 object API) with sub-pixel corner refinement. Marker
poses come from ``solvePnP`` with ``SOLVEPNP_IPPE_SQUARE`` (object corners top-left, top-right, bottom-right,
bottom-left at (-s/2, +s/2), (+s/2, +s/2), (+s/2, -s/2), (-s/2, -s/2)); the marker frame has x along the printed
image's x axis, y toward its top and z out of the printed face, which on a brick coincides with the brick frame.

Bricks: brick k carries marker 2k at +spacing/2 and marker 2k+1 at -spacing/2 along its length (+x) axis, both on
the top face. :func:`estimate_bricks` fits ONE pose per brick to all visible corners of its markers with their
known layout (8 corners, or 4 when a marker is hidden). Two markers 17.5 cm apart fix the scale, and so the
depth, far better than one 5 cm marker alone; per-marker poses (:func:`detect_tags`) are what the paper's
filter (:func:`masonry.perception.estimation.estimate_brick_pose`) takes.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from masonry.blueprint import MarkerSpec
from masonry.errors import InputError, PerceptionError
from masonry.perception.types import BrickEstimate, CameraIntrinsics, TagPose

if TYPE_CHECKING:
    from masonry.perception.estimation import EstimatorConfig

__all__ = [
    "DetectedMarker",
    "aruco_dictionary",
    "brick_corner_layout",
    "detect_markers",
    "detect_tags",
    "estimate_bricks",
    "yaw_about_rad",
]

_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.001)


@dataclass(frozen=True, eq=False)
class DetectedMarker:
    """One marker found in an image: its id and its four corners in pixels (TL, TR, BR, BL), shape (4, 2)."""

    marker_id: int
    corners_px: np.ndarray


def known_dictionaries() -> tuple[str, ...]:
    """Names of OpenCV's predefined ArUco dictionaries (``DICT_4X4_50`` ...)."""
    return tuple(
        sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_") and isinstance(getattr(cv2.aruco, n), int))
    )


@functools.lru_cache(maxsize=16)
def aruco_dictionary(name: str) -> cv2.aruco.Dictionary:
    """OpenCV's predefined dictionary called ``name``.

    Raises:
        PerceptionError: the name is not one of OpenCV's predefined dictionaries.
    """
    value = getattr(cv2.aruco, name, None) if name.startswith("DICT_") else None
    if not isinstance(value, int):
        raise PerceptionError(
            f"unknown ArUco dictionary {name!r}; use one of OpenCV's predefined ones, e.g. DICT_4X4_50, "
            f"DICT_5X5_100, DICT_6X6_250, DICT_ARUCO_ORIGINAL, DICT_APRILTAG_36h11"
        )
    return cv2.aruco.getPredefinedDictionary(value)


@functools.lru_cache(maxsize=16)
def _detector(name: str) -> cv2.aruco.ArucoDetector:
    params = cv2.aruco.DetectorParameters()
    # Contour refinement is left off: we refine corners ourselves below, on the grey image, with a window
    # scaled to the marker's size (see _refine_corners).
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
    return cv2.aruco.ArucoDetector(aruco_dictionary(name), params, cv2.aruco.RefineParameters())


def _grey(image: np.ndarray) -> np.ndarray:
    if not isinstance(image, np.ndarray) or image.size == 0:
        raise InputError("image is empty or not an array")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if image.ndim == 3 and image.shape[2] in (3, 4):
        image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY if image.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
    if image.ndim != 2:
        raise InputError(f"image must be grey (H, W) or BGR (H, W, 3); got shape {image.shape}")
    if image.dtype != np.uint8:
        if np.issubdtype(image.dtype, np.floating) and float(np.nanmax(image)) <= 1.0:
            image = image * 255.0
        image = np.clip(image, 0, 255).astype(np.uint8)
    return image


def _refine_corners(grey: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Sub-pixel corners: ``cornerSubPix`` with a window of about a fifth of the marker's shortest side."""
    side = float(np.min(np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1)))
    half = int(max(2, min(6, round(side / 10.0))))
    refined = cv2.cornerSubPix(
        grey, corners.reshape(-1, 1, 2).astype(np.float32), (half, half), (-1, -1), _SUBPIX_CRITERIA
    ).reshape(4, 2)
    # cornerSubPix can jump to a neighbouring feature on a blurred tiny marker: keep moves under a pixel or two.
    moved = np.linalg.norm(refined - corners, axis=1)
    return np.where((moved < 0.25 * half + 1.0)[:, None], refined, corners).astype(np.float64)  # type: ignore[no-any-return]


def detect_markers(image: np.ndarray, markers: MarkerSpec) -> list[DetectedMarker]:
    """Find the markers of ``markers.dictionary`` in ``image`` (grey or BGR), with sub-pixel corners.

    A marker id found twice keeps its larger instance. Raises PerceptionError for an unknown dictionary and
    InputError for an image that is not one.
    """
    detector = _detector(markers.dictionary)
    grey = _grey(image)
    corners, ids, _rejected = detector.detectMarkers(grey)
    if ids is None or len(ids) == 0:
        return []
    best: dict[int, DetectedMarker] = {}
    for c, marker_id in zip(corners, ids.ravel()):
        pts = _refine_corners(grey, np.asarray(c, dtype=np.float64).reshape(4, 2))
        found = DetectedMarker(int(marker_id), pts)
        old = best.get(found.marker_id)
        if old is None or _perimeter(pts) > _perimeter(old.corners_px):
            best[found.marker_id] = found
    return [best[k] for k in sorted(best)]


def _perimeter(corners: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1)))


def _marker_object_points(size_m: float) -> np.ndarray:
    h = size_m / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def brick_corner_layout(markers: MarkerSpec, marker_ids: tuple[int, ...]) -> np.ndarray:
    """Corners (TL, TR, BR, BL per marker) of a brick's markers in its top-face frame, shape (4 * n, 3).

    The top-face frame: origin at the top face's centre, x along the brick's length, y across, z up; marker 2k
    sits at (+spacing/2, 0, 0) and 2k+1 at (-spacing/2, 0, 0).
    """
    square = _marker_object_points(markers.size_m)
    rows = []
    for marker_id in marker_ids:
        along = 0.5 if marker_id % 2 == 0 else -0.5
        rows.append(square + np.array([along * markers.spacing_m, 0.0, 0.0]))
    return np.vstack(rows)


def _rotation(rvec: np.ndarray) -> np.ndarray:
    return cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3))[0]  # type: ignore[no-any-return]


def detect_tags(image: np.ndarray, intrinsics: CameraIntrinsics, markers: MarkerSpec) -> list[TagPose]:
    """Poses of every marker seen in ``image``, one ``solvePnP`` (IPPE_SQUARE) per marker, camera frame.

    Raises:
        PerceptionError: unknown dictionary.
        InputError: the image is not a grey or BGR array.
    """
    K, dist = intrinsics.matrix(), intrinsics.dist_coeffs()
    obj = _marker_object_points(markers.size_m)
    tags = []
    for m in detect_markers(image, markers):
        ok, rvec, tvec = cv2.solvePnP(obj, m.corners_px, K, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)
        if not ok:
            continue
        tags.append(TagPose(m.marker_id, np.asarray(tvec, dtype=float).reshape(3), _rotation(rvec)))
    return tags


def yaw_about_rad(
    direction: np.ndarray, up: tuple[float, float, float] | np.ndarray = (0.0, 0.0, 1.0)
) -> float:
    """Angle of ``direction`` projected on the plane orthogonal to ``up``, measured like atan2(y, x) about ``up``.

    The plane's reference axes are those of the frame rotated by the smallest rotation taking z onto ``up``,
    so for ``up = (0, 0, 1)`` this is exactly ``atan2(direction_y, direction_x)``.
    """
    u = np.asarray(up, dtype=float)
    u = u / np.linalg.norm(u)
    v = np.asarray(direction, dtype=float)
    z = np.array([0.0, 0.0, 1.0])
    c = float(u @ z)
    if c < -1.0 + 1e-12:
        R = np.diag([1.0, -1.0, -1.0])  # half turn about x takes z onto -z
    else:
        k = np.cross(z, u)
        Kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        R = np.eye(3) + Kx + Kx @ Kx / (1.0 + c)  # rotation taking z onto u (Rodrigues, unnormalised axis)
    local = R.T @ v
    return math.atan2(float(local[1]), float(local[0]))


def _fit_brick(
    obs: list[DetectedMarker], markers: MarkerSpec, K: np.ndarray, dist: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """One pose (R_cam_brick, top-face centre) for the corners of one brick's visible markers."""
    ids = tuple(m.marker_id for m in obs)
    obj = brick_corner_layout(markers, ids)
    img = np.vstack([m.corners_px for m in obs])
    if len(obs) == 1:
        # One square: IPPE_SQUARE on the marker's own corners, then the known offset to the brick's centre.
        ok, rvec, tvec = cv2.solvePnP(
            _marker_object_points(markers.size_m), img, K, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE
        )
        if not ok:
            return None
        R = _rotation(rvec)
        centre = np.asarray(tvec, dtype=float).reshape(3) - R @ obj[:4].mean(axis=0)
        return R, centre
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        return None
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, dist, rvec, tvec)
    return _rotation(rvec), np.asarray(tvec, dtype=float).reshape(3)


def estimate_bricks(
    image: np.ndarray,
    intrinsics: CameraIntrinsics,
    markers: MarkerSpec,
    config: EstimatorConfig | None = None,
) -> list[BrickEstimate]:
    """Top-face centre and yaw of every brick whose markers are seen in ``image`` (camera frame), sorted by id.

    All visible corners of a brick's markers are fitted jointly with their known layout (``markers.size_m`` and
    ``markers.spacing_m``). The yaw is the angle of the brick's +x axis about ``config.up`` (default the optical
    axis, i.e. in the image's x-y plane).

    Raises:
        PerceptionError: unknown dictionary.
        InputError: the image is not a grey or BGR array.
    """
    up = np.array([0.0, 0.0, 1.0]) if config is None else np.asarray(config.up, dtype=float)
    K, dist = intrinsics.matrix(), intrinsics.dist_coeffs()
    by_brick: dict[int, list[DetectedMarker]] = {}
    for m in detect_markers(image, markers):
        by_brick.setdefault(m.marker_id // 2, []).append(m)
    estimates = []
    for brick_id in sorted(by_brick):
        obs = sorted(by_brick[brick_id], key=lambda m: m.marker_id)
        fit = _fit_brick(obs, markers, K, dist)
        if fit is None:
            continue
        R, centre = fit
        estimates.append(
            BrickEstimate(brick_id, centre, yaw_about_rad(R[:, 0], up), tuple(m.marker_id for m in obs))
        )
    return estimates
