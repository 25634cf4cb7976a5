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

_MAX_JOINT_RMS_PX = (
    2.0  # reprojection RMS above which a brick's two markers are not taken as one rigid layout
)
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
    # OpenCV's refinement is left off: detect_markers refines corners itself by fitting lines to the edges.
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
    # Two adaptive-threshold windows (5 and 21 px) instead of OpenCV's three (3, 13, 23): the same markers found
    # on our test frames (0.6-2 m, blur up to 1.2 px) in two thirds of the time.
    params.adaptiveThreshWinSizeMin = 5
    params.adaptiveThreshWinSizeMax = 21
    params.adaptiveThreshWinSizeStep = 16
    # Read the bits from a 10-px-per-cell unwarped marker and ignore a quarter of each cell at its borders
    # (OpenCV: 4 px, 13 %): small blurred markers (15-20 px at 1.5-2.2 m) decode far more often, with no false
    # ids on our test frames (257 instead of 216 of 320 markers found) and no extra time.
    params.perspectiveRemovePixelPerCell = 10
    params.perspectiveRemoveIgnoredMarginPerCell = 0.25
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


def _subpix_corners(grey: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Fallback refinement: ``cornerSubPix`` with a window of about a fifth of the marker's shortest side."""
    side = float(np.min(np.linalg.norm(corners - np.roll(corners, 1, axis=0), axis=1)))
    half = int(max(2, min(6, round(side / 10.0))))
    refined = cv2.cornerSubPix(
        grey, corners.reshape(-1, 1, 2).astype(np.float32), (half, half), (-1, -1), _SUBPIX_CRITERIA
    ).reshape(4, 2)
    # cornerSubPix can jump to a neighbouring feature on a tiny marker: keep only small moves.
    moved = np.linalg.norm(refined - corners, axis=1)
    return np.where((moved < 0.25 * half + 1.0)[:, None], refined, corners).astype(np.float64)


_EDGE_SAMPLES = 12  # profiles per side, spread over its middle (away from the rounded-off corners)
_PROFILE_SAMPLES = 17  # samples across the edge per profile


def _edge_points(grey_f: np.ndarray, corners: np.ndarray, cells: int) -> np.ndarray:
    """Sub-pixel points on the four outer edges of each marker, shape (m, 4, n, 2), NaN where none was found.

    Along each side an intensity profile is sampled across the edge (one ``remap`` for every marker at once);
    the edge is where the profile crosses half-way between the black border and the white surround. For a
    straight step blurred by any symmetric point-spread function that crossing is exactly on the edge, which
    is why lines fitted through these points meet at the true corner, where gradient-based corner finders sit
    inside a blurred convex corner (0.2-0.4 px here: a 1 % scale error on a 25 px marker).

    Args:
        grey_f: the image as float32.
        corners: (m, 4, 2) detected corners (TL, TR, BR, BL) of m markers.
        cells: cells across a marker including its black border (6 for 4x4 dictionaries).
    """
    m = corners.shape[0]
    nxt = np.roll(corners, -1, axis=1)
    side = np.linalg.norm(nxt - corners, axis=2)  # (m, 4)
    # Reach across the edge: within the one-cell black border inside and the one-cell white margin outside.
    reach = np.clip(0.8 * side.min(axis=1) / cells, 1.0, 4.0)  # (m,)
    offsets = np.linspace(-1.0, 1.0, _PROFILE_SAMPLES)[None, :] * reach[:, None]  # (m, P)
    t = (nxt - corners) / side[..., None]
    normal = np.stack([t[..., 1], -t[..., 0]], axis=-1)  # (m, 4, 2)
    outward = np.einsum("msk,msk->ms", (corners + nxt) / 2.0 - corners.mean(axis=1, keepdims=True), normal)
    normal = np.where((outward < 0.0)[..., None], -normal, normal)
    s = np.linspace(0.18, 0.82, _EDGE_SAMPLES)
    base = corners[:, :, None, :] + s[None, None, :, None] * (nxt - corners)[:, :, None, :]  # (m, 4, n, 2)
    grid = base[:, :, :, None, :] + offsets[:, None, None, :, None] * normal[:, :, None, None, :]
    flat = grid.reshape(-1, _PROFILE_SAMPLES, 2).astype(np.float32)
    prof = cv2.remap(grey_f, flat[..., 0], flat[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    mid = _PROFILE_SAMPLES // 2
    dark = prof[:, :mid].min(axis=1)
    light = prof[:, mid + 1 :].max(axis=1)
    # One level per side (medians over its profiles): steadier than per profile under noise.
    per_side = (m * 4, _EDGE_SAMPLES)
    side_dark = np.median(dark.reshape(per_side), axis=1)
    side_light = np.median(light.reshape(per_side), axis=1)
    level = np.repeat((side_dark + side_light) / 2.0, _EDGE_SAMPLES)
    cross = (prof[:, :-1] < level[:, None]) & (prof[:, 1:] >= level[:, None])
    rank = np.where(cross, np.abs(np.arange(_PROFILE_SAMPLES - 1) + 0.5 - mid), np.inf)
    j = np.argmin(rank, axis=1)
    rows = np.arange(len(prof))
    ok = np.isfinite(rank[rows, j]) & (light - dark > 12.0)
    lo, hi = prof[rows, j], prof[rows, j + 1]
    frac = np.where(hi > lo, (level - lo) / np.where(hi > lo, hi - lo, 1.0), 0.5)
    step = np.repeat(2.0 * reach / (_PROFILE_SAMPLES - 1), 4 * _EDGE_SAMPLES)
    edge = -np.repeat(reach, 4 * _EDGE_SAMPLES) + (j + frac) * step
    pts = base.reshape(-1, 2) + edge[:, None] * np.repeat(normal.reshape(-1, 2), _EDGE_SAMPLES, axis=0)
    pts[~ok] = np.nan
    return pts.reshape(m, 4, _EDGE_SAMPLES, 2)  # type: ignore[no-any-return]


def _fit_line(p: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Total-least-squares line (point, unit normal) through ``p`` with one round of outlier rejection."""
    p = p[np.isfinite(p[:, 0])]
    mu = normal = None
    for _ in range(2):
        if len(p) < 3:
            return None
        mu = p.mean(axis=0)
        d = p - mu
        sxx, syy, sxy = float(d[:, 0] @ d[:, 0]), float(d[:, 1] @ d[:, 1]), float(d[:, 0] @ d[:, 1])
        angle = 0.5 * math.atan2(2.0 * sxy, sxx - syy)  # direction of largest spread
        normal = np.array([-math.sin(angle), math.cos(angle)])
        res = d @ normal
        keep = np.abs(res) < max(0.3, 2.5 * float(np.sqrt(np.mean(res * res))))
        if keep.all():
            break
        p = p[keep]
    assert mu is not None and normal is not None
    return mu, normal


def _corners_from_edges(
    pts: np.ndarray, corners: np.ndarray, K: np.ndarray | None = None, dist: np.ndarray | None = None
) -> np.ndarray | None:
    """One marker's corners as intersections of lines fitted to its edge points (4, n, 2); None if unclean.

    With lens distortion the edge points are undistorted first (a straight edge is straight only in the
    ideal pinhole image) and the corners distorted back to pixels.
    """
    distorted = K is not None and dist is not None and bool(np.any(dist != 0.0))
    if K is not None and dist is not None and distorted:
        flat = pts.reshape(-1, 2)
        good = np.isfinite(flat[:, 0])
        ideal = np.full_like(flat, np.nan)
        if good.any():
            ideal[good] = cv2.undistortPoints(flat[good].reshape(-1, 1, 2), K, dist, P=K).reshape(-1, 2)
        pts = ideal.reshape(pts.shape)
    lines = [_fit_line(pts[i]) for i in range(4)]
    out = np.empty((4, 2))
    for i in range(4):
        l1, l2 = lines[(i - 1) % 4], lines[i]
        if l1 is None or l2 is None:
            return None
        A = np.array([l1[1], l2[1]])
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        if abs(det) < 1e-6:
            return None
        b0, b1 = l1[1] @ l1[0], l2[1] @ l2[0]
        out[i] = ((A[1, 1] * b0 - A[0, 1] * b1) / det, (A[0, 0] * b1 - A[1, 0] * b0) / det)
    if K is not None and dist is not None and distorted:
        norm = np.column_stack([(out[:, 0] - K[0, 2]) / K[0, 0], (out[:, 1] - K[1, 2]) / K[1, 1], np.ones(4)])
        projected = cv2.projectPoints(norm, np.zeros(3), np.zeros(3), K, dist)[0]
        out = np.asarray(projected, dtype=float).reshape(4, 2)
    if float(np.max(np.linalg.norm(out - corners, axis=1))) > 2.0:
        return None  # the lines met far from the detected corner: something else shares the edge
    return out


def detect_markers(
    image: np.ndarray, markers: MarkerSpec, intrinsics: CameraIntrinsics | None = None
) -> list[DetectedMarker]:
    """Find the markers of ``markers.dictionary`` in ``image`` (grey or BGR), with sub-pixel corners (pixels).

    Corners are refined by fitting lines to the markers' outer edges (see :func:`_edge_points`), falling back to
    ``cornerSubPix``; ``intrinsics`` (optional) lets the fit undo lens distortion. A marker id found twice keeps
    its larger instance.

    Raises:
        PerceptionError: unknown dictionary.
        InputError: the image is not a grey or BGR array.
    """
    detector = _detector(markers.dictionary)
    cells = aruco_dictionary(markers.dictionary).markerSize + 2
    grey = _grey(image)
    corners, ids, _rejected = detector.detectMarkers(grey)
    if ids is None or len(ids) == 0:
        return []
    grey_f = grey.astype(np.float32)
    K = dist = None
    if intrinsics is not None:
        K, dist = intrinsics.matrix(), intrinsics.dist_coeffs()
    raw_all = np.asarray(corners, dtype=np.float64).reshape(-1, 4, 2)
    edges = _edge_points(grey_f, raw_all, cells)
    best: dict[int, DetectedMarker] = {}
    for raw, edge, marker_id in zip(raw_all, edges, ids.ravel()):
        pts = _corners_from_edges(edge, raw, K, dist)
        if pts is None:
            pts = _subpix_corners(grey, raw)
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
    return cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3))[0]


def detect_tags(
    image: np.ndarray,
    intrinsics: CameraIntrinsics,
    markers: MarkerSpec,
    *,
    up: tuple[float, float, float] | None = (0.0, 0.0, 1.0),
) -> list[TagPose]:
    """Poses of every marker seen in ``image``, one ``solvePnP`` (IPPE_SQUARE) per marker, camera frame.

    ``up`` (camera frame; default the optical axis) settles the two-fold tilt ambiguity of a small square seen
    head-on when both poses fit the corners within noise: the one whose normal is closer to that line wins.
    Pass None to keep the best-fitting pose always.

    Raises:
        PerceptionError: unknown dictionary.
        InputError: the image is not a grey or BGR array.
    """
    K, dist = intrinsics.matrix(), intrinsics.dist_coeffs()
    up_vec = None if up is None else np.asarray(up, dtype=float) / np.linalg.norm(up)
    tags = []
    for m in detect_markers(image, markers, intrinsics):
        pose = _square_pose(m.corners_px, markers.size_m, K, dist, up_vec)
        if pose is not None:
            tags.append(TagPose(m.marker_id, pose[1], pose[0]))
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
        # 1 / (1 + c) without cancellation when up is close to -z (1 - c^2 = |k|^2), as estimation.yaw_about_rad:
        # with up (1e-5, 0, -1) the plain quotient was off by 8e-8 rad (hypothesis found it)
        s = (1.0 - c) / float(k @ k) if c < 0.0 else 1.0 / (1.0 + c)
        R = np.eye(3) + Kx + Kx @ Kx * s  # rotation taking z onto u (Rodrigues, unnormalised axis)
    local = R.T @ v
    return math.atan2(float(local[1]), float(local[0]))


def _square_pose(
    corners_px: np.ndarray, size_m: float, K: np.ndarray, dist: np.ndarray, up: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray] | None:
    """Pose (R_cam_marker, centre) of one square marker by IPPE_SQUARE.

    A square seen nearly head-on has two poses that fit its corners almost equally well (the tilt "flip"). When
    both fit within noise, take the one whose normal lies closer to the ``up`` line: markers lie flat on bricks
    and the camera looks down on them, so the plane normal is known roughly. With ``up`` None, the best fit wins.
    """
    obj = _marker_object_points(size_m)
    try:
        n, rvecs, tvecs, errs = cv2.solvePnPGeneric(obj, corners_px, K, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    except cv2.error:
        return None
    if n == 0:
        return None
    errs_px = np.asarray(errs, dtype=float).ravel()
    best = int(np.argmin(errs_px))
    if up is not None and n > 1:
        near = [i for i in range(n) if errs_px[i] <= 2.0 * errs_px[best] + 0.25]
        best = max(near, key=lambda i: abs(float(_rotation(rvecs[i])[:, 2] @ up)))
    return _rotation(rvecs[best]), np.asarray(tvecs[best], dtype=float).reshape(3)


def _fit_brick(
    obs: list[DetectedMarker], markers: MarkerSpec, K: np.ndarray, dist: np.ndarray, up: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]] | None:
    """One pose (R_cam_brick, top-face centre, marker ids used) for the corners of one brick's markers."""
    ids = tuple(m.marker_id for m in obs)
    obj = brick_corner_layout(markers, ids)
    img = np.vstack([m.corners_px for m in obs])
    if len(obs) == 1:
        # One square: its own pose, then the known offset from the marker to the brick's centre.
        pose = _square_pose(img, markers.size_m, K, dist, up)
        if pose is None:
            return None
        R, t = pose
        return R, t - R @ obj[:4].mean(axis=0), ids
    ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_IPPE)
    if ok:
        rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, dist, rvec, tvec)
        projected = cv2.projectPoints(obj, rvec, tvec, K, dist)[0].reshape(-1, 2)
        rms_px = float(np.sqrt(np.mean(np.sum((projected - img) ** 2, axis=1))))
        if rms_px <= _MAX_JOINT_RMS_PX:
            return _rotation(rvec), np.asarray(tvec, dtype=float).reshape(3), ids
    # The two markers do not fit one brick (two bricks printed with the same id, a marker on a tilted sticker):
    # trust the larger marker alone.
    larger = max(obs, key=lambda m: _perimeter(m.corners_px))
    return _fit_brick([larger], markers, K, dist, up)


def estimate_bricks(
    image: np.ndarray,
    intrinsics: CameraIntrinsics,
    markers: MarkerSpec,
    config: EstimatorConfig | None = None,
) -> list[BrickEstimate]:
    """Top-face centre and yaw of every brick whose markers are seen in ``image`` (camera frame), sorted by id.

    All visible corners of a brick's markers are fitted jointly with their known layout (``markers.size_m`` and
    ``markers.spacing_m``). The yaw is the angle of the brick's +x axis about ``config.up`` (default the optical
    axis, i.e. in the image's x-y plane). ``tags`` lists the marker ids the estimate rests on: those seen, except
    when two seen markers do not fit one brick (reprojection RMS above 2 px, e.g. an id printed on two bricks);
    then only the larger marker is used.

    Raises:
        PerceptionError: unknown dictionary.
        InputError: the image is not a grey or BGR array.
    """
    up = np.array([0.0, 0.0, 1.0]) if config is None else np.asarray(config.up, dtype=float)
    K, dist = intrinsics.matrix(), intrinsics.dist_coeffs()
    by_brick: dict[int, list[DetectedMarker]] = {}
    for m in detect_markers(image, markers, intrinsics):
        by_brick.setdefault(m.marker_id // 2, []).append(m)
    estimates = []
    for brick_id in sorted(by_brick):
        obs = sorted(by_brick[brick_id], key=lambda m: m.marker_id)
        fit = _fit_brick(obs, markers, K, dist, up / np.linalg.norm(up))
        if fit is None:
            continue
        R, centre, used = fit
        estimates.append(BrickEstimate(brick_id, centre, yaw_about_rad(R[:, 0], up), used))
    return estimates
