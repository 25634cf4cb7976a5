"""The simulated downward camera: which markers it sees, and the noisy marker poses a detector would report.

A marker is seen when all four of its corners project inside the image, it faces the camera within
``max_view_angle_rad``, its smallest projected side is at least ``min_marker_px`` pixels (so there is a range
limit: 500 px focal length, 5 cm markers, 10 px -> 2.5 m), no brick rests on it (``covered``), and the brick the
UAV carries does not hide it. Other bricks in the line of sight do not occlude (markers sit on top faces, and
the camera looks down).

Noise on a seen marker's pose (camera frame), growing with the distance d in metres:
lateral (x, y) ``lateral_noise_m + lateral_noise_per_m * d``, depth (z) ``depth_noise_m + depth_noise_per_m * d``,
and a small random rotation of ``angle_noise_rad + angle_noise_per_m * d`` per axis (all standard deviations).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from masonry.blueprint import MarkerSpec
from masonry.geometry import R_world_body
from masonry.perception.types import DEFAULT_INTRINSICS, CameraIntrinsics, TagPose
from masonry.sim.bricks import SimBrick, point_in_rect

__all__ = ["DEFAULT_INTRINSICS", "CameraConfig", "LayoutCache", "R_world_body", "observe_markers"]


@dataclass(frozen=True)
class CameraConfig:
    """Simulated camera: intrinsics, detection limits, measurement noise and rendering parameters."""

    intrinsics: CameraIntrinsics = field(default_factory=lambda: DEFAULT_INTRINSICS)
    min_marker_px: float = 10.0
    max_view_angle_rad: float = math.radians(70.0)
    lateral_noise_m: float = 0.002
    lateral_noise_per_m: float = 0.002
    depth_noise_m: float = 0.005
    depth_noise_per_m: float = 0.005
    angle_noise_rad: float = 0.005
    angle_noise_per_m: float = 0.005
    blur_sigma_px: float = 0.6  # render mode
    noise_sigma: float = 2.0  # render mode, grey levels

    def max_range_m(self, marker_size_m: float) -> float:
        """Farthest distance at which a marker still spans ``min_marker_px`` pixels."""
        return max(self.intrinsics.fx, self.intrinsics.fy) * marker_size_m / self.min_marker_px

    def half_diagonal_tan(self) -> float:
        """Tangent of the half-angle from the optical axis to the farthest image corner."""
        i = self.intrinsics
        return math.hypot(max(i.cx, i.width_px - i.cx) / i.fx, max(i.cy, i.height_px - i.cy) / i.fy)


def _marker_points(brick: SimBrick, markers: MarkerSpec) -> np.ndarray:
    """The brick's two marker centres then their 4 + 4 corners (world, (10, 3)), cached while the brick does not move."""
    key = (brick.position_m, brick.yaw_rad, markers)
    cache = brick.marker_cache
    if cache is not None and cache[0] == key:
        return cache[1]  # type: ignore[return-value]
    x, y, _ = brick.position_m
    top = brick.top_z_m
    c, s = math.cos(brick.yaw_rad), math.sin(brick.yaw_rad)
    half = markers.spacing_m / 2.0
    h = markers.size_m / 2.0
    centres = [(x + c * half, y + s * half), (x - c * half, y - s * half)]
    points = [(mx, my, top) for mx, my in centres]
    for mx, my in centres:
        # top-left, top-right, bottom-right, bottom-left in the marker's own frame (x along the brick's +x)
        for dx, dy in ((-h, h), (h, h), (h, -h), (-h, -h)):
            points.append((mx + c * dx - s * dy, my + s * dx + c * dy, top))
    array = np.array(points, dtype=float)  # converted once per pose, not on every frame
    brick.marker_cache = (key, array)
    return array


def marker_layout(
    bricks: Sequence[SimBrick], markers: MarkerSpec
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Marker ids (m,), centres (m, 3) and corners (m, 4, 3) in the world for the bricks' top faces."""
    n = len(bricks)
    if n == 0:  # (a frame over no brick: a UAV over bare ground)
        return np.zeros(0, dtype=int), np.zeros((0, 3)), np.zeros((0, 4, 3))
    ids: list[int] = []
    for b in bricks:
        ids.extend(b.blueprint.marker_ids())
    P = np.concatenate([_marker_points(b, markers) for b in bricks]).reshape(n, 10, 3)
    return np.array(ids, dtype=int), P[:, 0:2].reshape(2 * n, 3), P[:, 2:10].reshape(2 * n, 4, 3)


Layout = tuple[np.ndarray, np.ndarray, np.ndarray]


class LayoutCache:
    """:func:`marker_layout` of a world's frames, kept while the same bricks are asked and none of them moved:
    the resting ones do not move while the field's ``version`` stays (:class:`masonry.sim.bricks.BrickField`).
    Consecutive frames of a climb ask the same bricks (on a 20-course wall ~110 of them): the arrays of the resting
    ones (the candidates up to the first carried brick) are built once, not concatenated again every frame; the
    carried ones after them (the fleet's, appended to every frame's candidates, moving every tick) are laid out
    each frame and joined to them: the same arrays as :func:`marker_layout` of all of them. With the resting
    ones' layout it keeps their yaws and each of their markers' ``covered`` answer (asked at the first frame that
    has the marker in view): :meth:`uncovered` and :meth:`yaw_rad` of the last :meth:`layout`."""

    def __init__(self) -> None:
        self._key: tuple[object, ...] | None = None
        self._layout: Layout | None = None
        self._covered = np.zeros(0, dtype=np.int8)  # (per resting row: -1 not asked yet, else the answer)
        self._yaw = np.zeros(0)  # (per resting row: its brick's yaw)
        self._rest_rows = 0  # (the resting rows at the head of the last layout)
        self._carried: Sequence[SimBrick] = ()  # (the last layout's bricks after them)

    def layout(self, bricks: Sequence[SimBrick], markers: MarkerSpec, version: int) -> Layout:
        n = len(bricks)
        cut = 0
        while cut < n and bricks[cut].state != "carried":
            cut += 1
        self._carried, self._rest_rows = bricks[cut:], 2 * cut
        if cut == 0:
            return marker_layout(bricks, markers)
        key = (version, markers, tuple([b.id for b in bricks[:cut]]))
        if self._layout is None or key != self._key:
            self._key, self._layout = key, marker_layout(bricks[:cut], markers)
            self._covered = np.full(2 * cut, -1, dtype=np.int8)
            self._yaw = np.repeat(np.array([b.yaw_rad for b in bricks[:cut]]), 2)
        if cut == n:
            return self._layout
        ids, centres, corners = self._layout
        more = marker_layout(bricks[cut:], markers)
        return (
            np.concatenate([ids, more[0]]),
            np.concatenate([centres, more[1]]),
            np.concatenate([corners, more[2]]),
        )

    def uncovered(
        self, index: np.ndarray, centres: np.ndarray, covered: Callable[[float, float, float], bool]
    ) -> np.ndarray:
        """The rows of ``index`` (ascending, rows of the last layout, whose ``centres`` these are) whose marker
        ``covered`` does not say covered, in order: the resting rows' answers kept, the carried rows' asked."""
        cut = int(np.searchsorted(index, self._rest_rows))
        rest, more = index[:cut], index[cut:]
        if cut:
            state = self._covered
            todo = rest[state[rest] < 0]
            for i, p in zip(todo.tolist(), centres[todo].tolist(), strict=True):
                state[i] = covered(*p)
            rest = rest[state[rest] == 0]
        if not len(more):
            return rest
        xyz = centres[more].tolist()
        more = np.array([i for i, p in zip(more.tolist(), xyz, strict=True) if not covered(*p)], dtype=int)
        return np.concatenate([rest, more]) if cut else more

    def maybe_seen(self) -> np.ndarray | None:
        """The rows of the last layout not known to be covered (ascending: the resting rows whose kept answer is
        not "covered", then every carried row), or None: all of them (none known covered, or one row alone left,
        whose matrix-vector product numpy takes another way than two rows' or more)."""
        state = self._covered[: self._rest_rows]
        if not (state > 0).any():
            return None
        rows = np.flatnonzero(state <= 0)
        if self._carried:
            rows = np.concatenate(
                [rows, np.arange(self._rest_rows, self._rest_rows + 2 * len(self._carried))]
            )
        return rows if len(rows) >= 2 else None

    def yaw_rad(self) -> np.ndarray:
        """The yaw of each row's brick in the last layout (the resting rows' kept)."""
        if not self._rest_rows:
            return np.repeat(np.array([b.yaw_rad for b in self._carried]), 2)
        if not self._carried:
            return self._yaw
        return np.concatenate([self._yaw, np.repeat(np.array([b.yaw_rad for b in self._carried]), 2)])


def observe_markers(
    R_wc: np.ndarray,
    c_w: np.ndarray,
    bricks: Sequence[SimBrick],
    markers: MarkerSpec,
    config: CameraConfig,
    rng: np.random.Generator,
    *,
    hidden: frozenset[int] | set[int] = frozenset(),
    occluder: SimBrick | None = None,
    covered: Callable[[float, float, float], bool] | None = None,
    layout: Layout | None = None,
    kept: LayoutCache | None = None,
) -> tuple[TagPose, ...]:
    """Noisy camera-frame poses of the markers of ``bricks`` seen by a camera at ``c_w`` with rotation ``R_wc``.

    Args:
        R_wc: 3x3 rotation of the camera frame (x right, y down, z forward) in the world.
        c_w: camera centre in the world (3,).
        bricks: candidate bricks (those near the camera).
        markers: marker size and spacing.
        config: intrinsics, limits and noise.
        rng: randomness for the measurement noise.
        hidden: marker ids not to report (occlusion fault).
        occluder: the brick this UAV carries: markers behind it are not seen.
        covered: whether a marker centre (x, y, z) lies under a brick resting on it.
        layout: ``marker_layout(bricks, markers)`` if the caller keeps it (:class:`LayoutCache`; not modified).
        kept: the cache whose last :meth:`LayoutCache.layout` gave ``layout`` (of these ``bricks``): its kept
            ``covered`` answers and yaws are read (the answers and floats asking again would give).
    """
    if not bricks:
        return ()
    intr = config.intrinsics
    ids, centres, corners = marker_layout(bricks, markers) if layout is None else layout
    # the rows a kept answer says covered are dropped before projecting (LayoutCache.maybe_seen): every row below
    # is its own (the same floats with or without the others), and a covered row would be dropped after it
    pre = kept.maybe_seen() if covered is not None and kept is not None else None
    at, at_corners = (centres, corners) if pre is None else (centres[pre], corners[pre])
    p_c = (at - c_w) @ R_wc  # camera frame = R_wc^T (p - c)
    q_c = (at_corners - c_w) @ R_wc  # (m, 4, 3)
    z = q_c[:, :, 2]
    front = z > 0.05
    zs = np.where(front, z, 1.0)
    u = intr.fx * q_c[:, :, 0] / zs + intr.cx
    v = intr.fy * q_c[:, :, 1] / zs + intr.cy
    # every corner in front of the camera and inside the image (one test per corner, then per row: _rows_all)
    ok = _rows_all(front & (u >= 0.0) & (u <= intr.width_px - 1.0) & (v >= 0.0) & (v <= intr.height_px - 1.0))
    dist = np.sqrt(np.add.reduce(p_c * p_c, axis=1))  # (np.linalg.norm(p_c, axis=1) without its checks)
    normal_c = R_wc[2, :]  # world +z (the markers' face normal) in the camera frame
    cos_view = -(p_c @ normal_c) / np.maximum(dist, 1e-9)
    ok &= cos_view >= math.cos(config.max_view_angle_rad)
    # side lengths corner k -> k+1 (cyclic): the differences np.diff gives on [u0, u1, u2, u3, u0]; of the rows
    # still in view only (each row's are its own), the smallest at least min_marker_px: all four at least that
    near = np.flatnonzero(ok)
    un, vn = u[near], v[near]
    near = near[
        _rows_all(np.hypot(un[:, _NEXT_CORNER] - un, vn[:, _NEXT_CORNER] - vn) >= config.min_marker_px)
    ]
    index = near if pre is None else pre[near]
    if hidden:
        index = np.array([i for i in index if int(ids[i]) not in hidden], dtype=int)
    if covered is not None and kept is not None and len(index):
        index = kept.uncovered(index, centres, covered)
    elif covered is not None and len(index):
        rows = index.tolist()
        xyz = centres[index].tolist()  # (one conversion of the markers in view, not one per marker)
        index = np.array([i for i, p in zip(rows, xyz, strict=True) if not covered(*p)], dtype=int)
    if occluder is not None and len(index):
        index = np.array([i for i in index if not _behind(occluder, c_w, centres[i])], dtype=int)
    if not len(index):
        return ()
    local = index if pre is None else np.searchsorted(pre, index)  # (the rows' places in the projected ones)
    d = dist[local]
    noise = rng.standard_normal((len(index), 6))
    lat = config.lateral_noise_m + config.lateral_noise_per_m * d
    dep = config.depth_noise_m + config.depth_noise_per_m * d
    ang = config.angle_noise_rad + config.angle_noise_per_m * d
    pos = p_c[local] + noise[:, :3] * np.stack([lat, lat, dep], axis=1)
    yaw = (np.repeat(np.array([b.yaw_rad for b in bricks]), 2) if kept is None else kept.yaw_rad())[index]
    cy, sy = np.cos(yaw), np.sin(yaw)
    R_wm = np.zeros((len(index), 3, 3))
    R_wm[:, 0, 0], R_wm[:, 0, 1], R_wm[:, 1, 0], R_wm[:, 1, 1], R_wm[:, 2, 2] = cy, -sy, sy, cy, 1.0
    R = np.einsum("ji,njk,nkl->nil", R_wc, R_wm, _rotvecs_to_matrices(noise[:, 3:] * ang[:, None]))
    return tuple(
        TagPose(marker_id=int(ids[i]), position_m=pos[row], R_cam_marker=R[row])
        for row, i in enumerate(index)
    )


_NEXT_CORNER = np.array([1, 2, 3, 0])
_ALL_FOUR = int.from_bytes(b"\x01\x01\x01\x01", "little")  # (four true bytes read as one 32-bit word)


def _rows_all(b: np.ndarray) -> np.ndarray:
    """``np.all(b, axis=1)`` of a fresh (m, 4) boolean array: its rows' four bytes read as one 32-bit word (a
    reduction along a short axis costs numpy more than the comparison does)."""
    every: np.ndarray = b.view(np.uint32)[:, 0] == _ALL_FOUR
    return every


_EYE3 = np.eye(3)[None]
_EYE3.flags.writeable = False


def _rotvecs_to_matrices(w: np.ndarray) -> np.ndarray:
    """Rodrigues' formula for a batch of rotation vectors (n, 3) -> (n, 3, 3)."""
    theta = np.sqrt(np.add.reduce(w * w, axis=1))  # (np.linalg.norm(w, axis=1) without its checks)
    safe = np.where(theta > 1e-12, theta, 1.0)
    k = w / safe[:, None]
    K = np.zeros((len(w), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    sin = np.where(theta > 1e-12, np.sin(theta), 0.0)[:, None, None]
    cos = np.where(theta > 1e-12, 1.0 - np.cos(theta), 0.0)[:, None, None]
    return _EYE3 + sin * K + cos * (K @ K)


def _behind(occluder: SimBrick, c_w: np.ndarray, p_w: np.ndarray) -> bool:
    """Whether the segment camera -> marker crosses the top face of the carried brick (and the marker is not on it)."""
    top = occluder.top_z_m
    if p_w[2] >= top - 1e-6 or c_w[2] <= top:
        return False
    t = (top - c_w[2]) / (p_w[2] - c_w[2])
    qx = c_w[0] + t * (p_w[0] - c_w[0])
    qy = c_w[1] + t * (p_w[1] - c_w[1])
    return point_in_rect(qx, qy, *occluder.rect())
