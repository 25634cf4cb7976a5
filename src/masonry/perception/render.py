"""Synthetic downward-camera frames of bricks carrying their ArUco markers, for the simulator and the benchmarks.

The scene: a textured ground plane (world z = 0) under a sun, brick bodies as shaded boxes casting shadows on
the ground, and on each brick's top face its two markers printed on white stickers (marker 2k at +spacing/2 on
the brick's length axis, 2k+1 at -spacing/2, image x along the brick's +x, image top toward the brick's +y).
The markers come from ``cv2.aruco.generateImageMarker`` and are warped into place by the exact plane-to-image
homography, at a texture resolution close to the projected one, so the edges the detector sees are where the
geometry puts them. Then lens distortion (if the intrinsics have any), optical blur, vignetting, exposure and
sensor noise. Pixel coordinates follow OpenCV: integer coordinates are pixel centres.

A 640x480 frame takes a few milliseconds (see ``benchmarks/bench_pose_pipeline.py``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from masonry.blueprint import DEFAULT_BRICK_SIZE_M, MarkerSpec
from masonry.errors import PerceptionError
from masonry.perception.aruco import aruco_dictionary
from masonry.perception.types import CameraIntrinsics

__all__ = ["RenderedBrick", "look_down", "random_view", "render_frame"]

_NEAR_M = 0.02  # near clipping plane in front of the camera
_SUN = np.array([0.35, 0.2, 0.915])  # direction toward the sun (world ENU), about 66 degrees high
_SUN = _SUN / np.linalg.norm(_SUN)
_AMBIENT = 0.35
_DIFFUSE = 0.65
_EXPOSURE = 255.0 * 1.05  # grey level of an albedo-1 surface lit head-on
_PAPER_ALBEDO = 0.85
_INK_ALBEDO = 0.07
_GROUND_ALBEDO = 0.42
_GROUND_TEXTURE_PX = 512
_GROUND_TEXTURE_RES_M = 0.002  # one ground-texture pixel, metres (period 1.024 m)
_SHIFT = 4  # sub-pixel bits for polygon filling
_SCALE = float(1 << _SHIFT)


@dataclass(frozen=True)
class RenderedBrick:
    """A brick to draw: id (its markers are 2m and 2m+1, m = ``marker`` or the id), centre of its box, yaw about z."""

    brick_id: int
    position_m: tuple[float, float, float]
    yaw_rad: float
    size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M
    marker: int | None = None  # a big wall's reused marker number (masonry.marker_reuse)


def render_frame(
    intrinsics: CameraIntrinsics,
    T_world_cam: np.ndarray,
    bricks: Sequence[RenderedBrick],
    markers: MarkerSpec,
    *,
    rng: np.random.Generator | int | None,
    blur_sigma_px: float = 0.6,
    noise_sigma: float = 2.0,
    hidden_markers: frozenset[int] = frozenset(),
) -> np.ndarray:
    """Draw one grey camera frame of ``bricks`` seen from the camera pose ``T_world_cam``.

    Args:
        intrinsics: pinhole intrinsics, distortion and image size of the camera.
        T_world_cam: 4x4 pose of the camera in the world (camera frame x right, y down, z forward).
        bricks: the bricks in view (others are simply not drawn).
        markers: dictionary, side length and spacing of the markers.
        rng: randomness for exposure and sensor noise (a Generator, or a seed).
        blur_sigma_px: Gaussian optical blur, pixels (0 for none).
        noise_sigma: standard deviation of the additive sensor noise, grey levels (0 for none).
        hidden_markers: marker ids not to draw (occluded or torn off).

    Returns:
        ``(height_px, width_px)`` uint8 image.
    """
    gen = np.random.default_rng(rng)
    T = np.asarray(T_world_cam, dtype=float)
    if T.shape != (4, 4):
        raise ValueError(f"T_world_cam must be 4x4, got shape {T.shape}")
    R_cw = T[:3, :3].T
    t_cw = -R_cw @ T[:3, 3]
    w, h = intrinsics.width_px, intrinsics.height_px
    distorted = any(abs(k) > 0.0 for k in intrinsics.distortion)
    if distorted:
        # Draw the ideal pinhole image on a canvas large enough to hold everything the lens folds into view.
        map_x, map_y, mx, my = _distortion_maps(
            intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy, tuple(intrinsics.distortion), w, h
        )
        canvas = CameraIntrinsics(
            intrinsics.fx,
            intrinsics.fy,
            intrinsics.cx + mx,
            intrinsics.cy + my,
            width_px=w + 2 * mx,
            height_px=h + 2 * my,
        )
    else:
        canvas = intrinsics
    cam = _Camera(canvas, R_cw, t_cw, T[:3, 3])

    image = _draw_ground(cam, bricks)
    order = sorted(bricks, key=lambda b: -float(np.linalg.norm(np.asarray(b.position_m) - cam.position_w)))
    for brick in order:
        _draw_brick(image, cam, brick, markers, hidden_markers)

    if distorted:
        image = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    if blur_sigma_px > 0.0:
        image = cv2.GaussianBlur(image, (0, 0), blur_sigma_px)
    gain = float(gen.uniform(0.92, 1.08))
    out = image.astype(np.float32)
    out *= _vignette(w, h) * gain
    if noise_sigma > 0.0:
        out += _noise_window(gen, w, h) * float(noise_sigma)
    return np.clip(out, 0.0, 255.0).astype(np.uint8)


def look_down(
    position_m: tuple[float, float, float] | np.ndarray,
    yaw_rad: float = 0.0,
    tilt_rad: float = 0.0,
    tilt_azimuth_rad: float = 0.0,
) -> np.ndarray:
    """4x4 ``T_world_cam`` of a camera at ``position_m`` looking down (optical axis along world -z).

    The image's x axis points along world (cos yaw, sin yaw, 0); the optical axis is then tilted ``tilt_rad``
    away from vertical, toward the horizontal direction at ``tilt_azimuth_rad`` in the camera's image plane.
    """
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    R_down = np.diag([1.0, -1.0, -1.0])
    axis = np.array([-math.sin(tilt_azimuth_rad), math.cos(tilt_azimuth_rad), 0.0])  # in the image plane
    R_tilt = cv2.Rodrigues(axis * tilt_rad)[0]
    T = np.eye(4)
    T[:3, :3] = Rz @ R_down @ R_tilt
    T[:3, 3] = np.asarray(position_m, dtype=float)
    return T


def random_view(
    rng: np.random.Generator,
    intrinsics: CameraIntrinsics,
    markers: MarkerSpec,
    *,
    n_bricks: int = 2,
    height_m: float = 1.2,
    max_tilt_rad: float = math.radians(5.0),
    brick_size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M,
    margin_px: float = 12.0,
    max_brick_id: int | None = None,
) -> tuple[np.ndarray, list[RenderedBrick]]:
    """A random test view: camera ``height_m`` above the tops of up to ``n_bricks`` bricks lying on the ground.

    Bricks get distinct random ids (their markers within the dictionary), random yaw, no overlap, and both
    markers inside the image by ``margin_px``; the camera has a random heading and up to ``max_tilt_rad`` of
    tilt. Returns ``(T_world_cam, bricks)`` for :func:`render_frame`.
    """
    count = aruco_dictionary(markers.dictionary).bytesList.shape[0] // 2
    if max_brick_id is not None:
        count = min(count, max_brick_id + 1)
    top_z = brick_size_m[2]
    T = look_down(
        (0.0, 0.0, top_z + height_m),
        float(rng.uniform(-math.pi, math.pi)),
        float(rng.uniform(0.0, max_tilt_rad)),
        float(rng.uniform(-math.pi, math.pi)),
    )
    R_cw, t_cw = T[:3, :3].T, -T[:3, :3].T @ T[:3, 3]
    K = intrinsics.matrix()
    half_w = height_m * intrinsics.width_px / (2.0 * intrinsics.fx)
    half_h = height_m * intrinsics.height_px / (2.0 * intrinsics.fy)
    reach = max(half_w, half_h)
    bricks: list[RenderedBrick] = []
    ids = [int(i) for i in rng.permutation(count)[: max(n_bricks, 1) * 4]]
    for _ in range(200 * max(n_bricks, 1)):
        if len(bricks) >= n_bricks or not ids:
            break
        b = RenderedBrick(
            ids[-1],
            (float(rng.uniform(-reach, reach)), float(rng.uniform(-reach, reach)), brick_size_m[2] / 2.0),
            float(rng.uniform(-math.pi, math.pi)),
            brick_size_m,
        )
        if any(
            math.dist(b.position_m[:2], o.position_m[:2]) < 1.15 * math.hypot(*brick_size_m[:2])
            for o in bricks
        ):
            continue
        R_wb = _brick_rotation(b.yaw_rad)
        top = np.asarray(b.position_m) + np.array([0.0, 0.0, brick_size_m[2] / 2.0])
        half = markers.spacing_m / 2.0 + markers.size_m
        pts = (
            np.array([[sx * half, sy * markers.size_m, 0.0] for sx in (-1, 1) for sy in (-1, 1)]) @ R_wb.T
            + top
        )
        uvw = (pts @ R_cw.T + t_cw) @ K.T
        uv = uvw[:, :2] / uvw[:, 2:3]
        inside = (
            (uv[:, 0] > margin_px).all()
            and (uv[:, 0] < intrinsics.width_px - 1 - margin_px).all()
            and (uv[:, 1] > margin_px).all()
            and (uv[:, 1] < intrinsics.height_px - 1 - margin_px).all()
        )
        if inside:
            bricks.append(b)
            ids.pop()
    return T, bricks


class _Camera:
    """Projection of world points for one frame (pinhole; distortion is applied to the finished image)."""

    def __init__(
        self, intr: CameraIntrinsics, R_cw: np.ndarray, t_cw: np.ndarray, position_w: np.ndarray
    ) -> None:
        self.K = intr.matrix()
        self.R_cw = R_cw
        self.t_cw = t_cw
        self.position_w = position_w
        self.width = intr.width_px
        self.height = intr.height_px

    def to_cam(self, p_w: np.ndarray) -> np.ndarray:
        return p_w @ self.R_cw.T + self.t_cw  # type: ignore[no-any-return]

    def project_cam(self, p_c: np.ndarray) -> np.ndarray:
        uvw = p_c @ self.K.T
        return uvw[:, :2] / uvw[:, 2:3]  # type: ignore[no-any-return]


def _clip_near(poly_c: np.ndarray) -> np.ndarray:
    """Clip a convex polygon (camera frame, (n, 3)) to z >= near (Sutherland-Hodgman against one plane)."""
    inside = poly_c[:, 2] >= _NEAR_M
    if inside.all():
        return poly_c
    out = []
    n = len(poly_c)
    for i in range(n):
        a, b = poly_c[i], poly_c[(i + 1) % n]
        a_in, b_in = a[2] >= _NEAR_M, b[2] >= _NEAR_M
        if a_in:
            out.append(a)
        if a_in != b_in:
            s = (_NEAR_M - a[2]) / (b[2] - a[2])
            out.append(a + s * (b - a))
    return np.array(out) if out else np.zeros((0, 3))


def _fill(image: np.ndarray, pts_px: np.ndarray, value: float) -> None:
    if len(pts_px) < 3:
        return
    p = np.round((pts_px + 0.0) * _SCALE).astype(np.int64)
    if np.abs(p).max() > 2**30:
        p = np.clip(p, -(2**30), 2**30)
    cv2.fillConvexPoly(image, p.astype(np.int32), round(min(255.0, max(0.0, value))), cv2.LINE_AA, _SHIFT)


def _shade(normal_w: np.ndarray) -> float:
    return _AMBIENT + _DIFFUSE * max(0.0, float(normal_w @ _SUN))


@functools.lru_cache(maxsize=4)
def _ground_texture() -> np.ndarray:
    """A periodic (tileable) concrete-like albedo texture: 1/f noise synthesised in the Fourier domain."""
    n = _GROUND_TEXTURE_PX
    gen = np.random.default_rng(20240517)
    spectrum = np.fft.fft2(gen.standard_normal((n, n)))
    f = np.hypot(*np.meshgrid(np.fft.fftfreq(n), np.fft.fftfreq(n), indexing="ij"))
    f[0, 0] = 1.0
    field = np.real(np.fft.ifft2(spectrum / f**0.9))
    field = (field - field.mean()) / field.std()
    grit = gen.standard_normal((n, n)) * 0.35  # fine grain of the surface
    albedo = _GROUND_ALBEDO * (1.0 + 0.18 * field + 0.06 * grit)
    ground: np.ndarray = np.clip(albedo * _EXPOSURE * _shade(np.array([0.0, 0.0, 1.0])), 0, 255)
    return ground.astype(np.uint8)


def _draw_ground(cam: _Camera, bricks: Sequence[RenderedBrick]) -> np.ndarray:
    """The ground plane z = 0 with brick shadows, warped at half resolution and upsampled (it is smooth)."""
    w, h = cam.width, cam.height
    hw, hh = (w + 1) // 2, (h + 1) // 2
    res = _GROUND_TEXTURE_RES_M
    period = _GROUND_TEXTURE_PX * res
    # Texture origin one period behind the camera's ground point, so texture coordinates stay small (OpenCV's
    # warp uses 16-bit fixed-point coordinates) while BORDER_WRAP tiles the plane.
    x0 = math.floor(cam.position_w[0] / period) * period - period
    y0 = math.floor(cam.position_w[1] / period) * period - period
    A = np.array(
        [[res, 0.0, x0 + 0.5 * res], [0.0, res, y0 + 0.5 * res], [0.0, 0.0, 1.0]]
    )  # texture -> ground
    H_img_ground = cam.K @ np.column_stack([cam.R_cw[:, 0], cam.R_cw[:, 1], cam.t_cw])
    H_full_half = np.array([[2.0, 0.0, 0.5], [0.0, 2.0, 0.5], [0.0, 0.0, 1.0]])
    M = np.linalg.inv(H_img_ground @ A) @ H_full_half  # half-res pixel -> texture pixel
    half = cv2.warpPerspective(
        _ground_texture(),
        M,
        (hw, hh),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_WRAP,
    )
    if bricks:
        shadow = np.full((hh, hw), 255, np.uint8)
        lit = _shade(np.array([0.0, 0.0, 1.0]))
        dark = round(255.0 * _AMBIENT / lit)
        to_half = np.array([[0.5, 0.0], [0.0, 0.5]])
        for b in bricks:
            corners = _box_corners(b)
            if corners[:, 2].min() < -1e-6:
                continue
            ground = corners - np.outer(corners[:, 2] / _SUN[2], _SUN)
            hull = cv2.convexHull(ground[:, :2].astype(np.float32)).reshape(-1, 2).astype(float)
            pts_c = _clip_near(cam.to_cam(np.column_stack([hull, np.zeros(len(hull))])))
            if len(pts_c) >= 3:
                px = cam.project_cam(pts_c)
                _fill(shadow, (px - 0.5) @ to_half, dark)
        half = cv2.multiply(half, shadow, scale=1.0 / 255.0)
    return cv2.resize(half, (w, h), interpolation=cv2.INTER_LINEAR)


def _brick_rotation(yaw_rad: float) -> np.ndarray:
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _box_corners(b: RenderedBrick) -> np.ndarray:
    L, W, H = b.size_m
    signs = np.array([[sx, sy, sz] for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)], dtype=float)
    local = signs * np.array([L, W, H]) / 2.0
    return local @ _brick_rotation(b.yaw_rad).T + np.asarray(b.position_m, dtype=float)  # type: ignore[no-any-return]


# Faces of the box by corner index (corner i has bits x=i&1, y=i&2, z=i&4), ordered around each face.
_FACES = (
    ((4, 5, 7, 6), (0.0, 0.0, 1.0)),
    ((0, 2, 3, 1), (0.0, 0.0, -1.0)),
    ((1, 3, 7, 5), (1.0, 0.0, 0.0)),
    ((0, 4, 6, 2), (-1.0, 0.0, 0.0)),
    ((2, 6, 7, 3), (0.0, 1.0, 0.0)),
    ((0, 1, 5, 4), (0.0, -1.0, 0.0)),
)


def _brick_albedo(brick_id: int) -> float:
    return 0.40 + 0.08 * ((brick_id * 2654435761) % 97) / 97.0  # fired clay, a little different per brick


def _draw_brick(
    image: np.ndarray, cam: _Camera, b: RenderedBrick, markers: MarkerSpec, hidden: frozenset[int]
) -> None:
    corners_w = _box_corners(b)
    R_wb = _brick_rotation(b.yaw_rad)
    albedo = _brick_albedo(b.brick_id)
    top_visible = False
    for idx, n_local in _FACES:
        n_w = R_wb @ np.asarray(n_local)
        face_w = corners_w[list(idx)]
        if float(n_w @ (cam.position_w - face_w[0])) <= 0.0:
            continue  # back face
        pts_c = _clip_near(cam.to_cam(face_w))
        if len(pts_c) < 3:
            continue
        _fill(image, cam.project_cam(pts_c), albedo * _EXPOSURE * _shade(n_w))
        if n_local[2] > 0.0:
            top_visible = True
    if not top_visible:
        return
    shade_top = _shade(R_wb[:, 2])
    center_top = np.asarray(b.position_m, dtype=float) + R_wb[:, 2] * (b.size_m[2] / 2.0)
    m = b.brick_id if b.marker is None else b.marker
    for marker_id, along in ((2 * m, 0.5), (2 * m + 1, -0.5)):
        if marker_id in hidden:
            continue
        _draw_marker(
            image,
            cam,
            markers,
            marker_id,
            center_top + R_wb[:, 0] * (along * markers.spacing_m),
            R_wb,
            shade_top,
        )


@functools.lru_cache(maxsize=1024)
def _sticker_texture(dictionary: str, marker_id: int, px_per_cell: int) -> np.ndarray:
    """The marker (black border included) on a white sticker one cell wider on each side, as albedo-grey."""
    d = aruco_dictionary(dictionary)
    count = d.bytesList.shape[0]
    if not 0 <= marker_id < count:
        raise PerceptionError(f"marker id {marker_id} is not in {dictionary} (ids 0..{count - 1})")
    cells = d.markerSize + 2
    img = cv2.aruco.generateImageMarker(d, marker_id, cells * px_per_cell, borderBits=1)
    img = cv2.copyMakeBorder(
        img, px_per_cell, px_per_cell, px_per_cell, px_per_cell, cv2.BORDER_CONSTANT, value=255
    )
    return np.where(img > 127, _PAPER_ALBEDO, _INK_ALBEDO).astype(np.float32)


def sticker_half_size_m(markers: MarkerSpec, marker_cells: int) -> float:
    """Half the side of the white sticker around a marker: the marker plus one cell of margin on each side."""
    return markers.size_m / 2.0 + markers.size_m / marker_cells


def _draw_marker(
    image: np.ndarray,
    cam: _Camera,
    markers: MarkerSpec,
    marker_id: int,
    center_w: np.ndarray,
    R_wm: np.ndarray,
    shade: float,
) -> None:
    cells = aruco_dictionary(markers.dictionary).markerSize + 2
    half = sticker_half_size_m(markers, cells)
    # Sticker corners in the marker frame: TL, TR, BR, BL of the texture (texture x -> +x, texture down -> -y).
    local = np.array([[-half, half, 0.0], [half, half, 0.0], [half, -half, 0.0], [-half, -half, 0.0]])
    pts_c = cam.to_cam(local @ R_wm.T + center_w)
    if pts_c[:, 2].min() < _NEAR_M:
        return
    dst = cam.project_cam(pts_c).astype(np.float64)
    side_px = float(np.max(np.linalg.norm(dst - np.roll(dst, 1, axis=0), axis=1)))
    texture_cells = cells + 2
    ppc = int(min(48, max(1, math.ceil(side_px / texture_cells))))
    tex = _sticker_texture(markers.dictionary, marker_id, ppc)
    n = tex.shape[0]
    src = np.array([[-0.5, -0.5], [n - 0.5, -0.5], [n - 0.5, n - 0.5], [-0.5, n - 0.5]])
    x0 = max(0, math.floor(dst[:, 0].min()) - 1)
    y0 = max(0, math.floor(dst[:, 1].min()) - 1)
    x1 = min(cam.width, math.ceil(dst[:, 0].max()) + 2)
    y1 = min(cam.height, math.ceil(dst[:, 1].max()) + 2)
    if x1 <= x0 or y1 <= y0:
        return
    H = cv2.getPerspectiveTransform(src.astype(np.float32), (dst - [x0, y0]).astype(np.float32))
    size = (x1 - x0, y1 - y0)
    colour = cv2.warpPerspective(
        tex * float(_EXPOSURE * shade),
        H,
        size,
        flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0,
    )
    alpha = cv2.warpPerspective(
        np.ones_like(tex), H, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0
    )
    roi = image[y0:y1, x0:x1]
    blended = roi.astype(np.float32) * (1.0 - alpha) + colour
    roi[...] = np.clip(blended, 0, 255).astype(np.uint8)


@functools.lru_cache(maxsize=8)
def _distortion_maps(
    fx: float, fy: float, cx: float, cy: float, dist: tuple[float, ...], w: int, h: int
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """For each pixel of the distorted image, where it comes from in the ideal pinhole image.

    Returns the two remap maps into an ideal canvas enlarged by a margin (mx, my) on each side, and the margin.
    """
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    pts = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
    ideal = cv2.undistortPoints(
        pts,
        K,
        np.asarray(dist, dtype=float),
        R=None,
        P=K,
        criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-6),
    ).reshape(h, w, 2)
    mx = math.ceil(max(0.0, -float(ideal[..., 0].min()), float(ideal[..., 0].max()) - (w - 1))) + 2
    my = math.ceil(max(0.0, -float(ideal[..., 1].min()), float(ideal[..., 1].max()) - (h - 1))) + 2
    mx, my = min(mx, w), min(my, h)  # a wild lens model must not make the canvas explode
    return (ideal[..., 0] + mx).astype(np.float32), (ideal[..., 1] + my).astype(np.float32), mx, my


@functools.lru_cache(maxsize=8)
def _vignette(w: int, h: int) -> np.ndarray:
    """Relative illumination of a typical small lens: cos^4-like falloff to about 80 % in the corners."""
    u, v = np.meshgrid(np.arange(w) - (w - 1) / 2.0, np.arange(h) - (h - 1) / 2.0)
    r2 = (u**2 + v**2) / ((w / 2.0) ** 2 + (h / 2.0) ** 2)
    return (1.0 - 0.2 * r2).astype(np.float32)  # type: ignore[no-any-return]


@functools.lru_cache(maxsize=8)
def _noise_field(w: int, h: int) -> np.ndarray:
    return np.random.default_rng(7919).standard_normal((2 * h, 2 * w), dtype=np.float32)


def _noise_window(gen: np.random.Generator, w: int, h: int) -> np.ndarray:
    """Unit Gaussian sensor noise: a random window of a cached field (fresh per frame, without the cost of
    drawing 300 k normals each time)."""
    field = _noise_field(w, h)
    oy = int(gen.integers(0, h + 1))
    ox = int(gen.integers(0, w + 1))
    window = field[oy : oy + h, ox : ox + w]
    flip = int(gen.integers(0, 4))
    if flip & 1:
        window = window[::-1]
    if flip & 2:
        window = window[:, ::-1]
    return window
