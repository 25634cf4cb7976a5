"""Brick pose from marker poses: the paper's marker filter solved exactly, pose from tags, moving window, confidence.

Paper Sec. IV (Brick Pose Estimation). The filter minimises, over the refined marker positions ``p1^, p2^``::

    J = w_prox (|p1^ - p1|^2 + |p2^ - p2|^2) + w_dist (|p1^ - p2^| - s)^2 + w_plane ((p1^ - p2^) . n)^2

The paper runs BFGS from the raw detections. With ``m = (p1^ + p2^)/2`` and ``d = p1^ - p2^`` the proximity term is
``2 w_prox |m - m_meas|^2 + w_prox/2 |d - d_meas|^2`` and the other terms involve ``d`` only, so the midpoint is
exactly the measured one and ``d`` solves a 3-D problem that reduces to a trust-region-like secular equation in one
unknown with a unique root, found by a monotone Newton iteration (docs/estimation.md has the derivation). The result
is the global minimum, not a local one, in a few microseconds. A consequence worth knowing: the filter keeps the
midpoint and the in-plane direction of the marker pair, so the two-tag centre and yaw are those of the raw detections.

Pure: numpy and the standard library only (scipy only inside the BFGS reference, imported on call).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from masonry.errors import InputError, PerceptionError
from masonry.perception.types import BrickEstimate, TagPose

C_TH = 0.75
#: The marker difference counts as along the plane normal below this fraction of its length off it (rounding).
_PARALLEL_TOL = 1e-9
"""The paper's confidence threshold: an estimate is trusted once its window's confidence reaches C_TH."""

Vec3Like = Sequence[float] | np.ndarray

__all__ = [
    "C_TH",
    "EstimatorConfig",
    "PoseWindow",
    "estimate_brick_pose",
    "marker_cost",
    "refine_markers",
    "refine_markers_bfgs",
    "yaw_about_rad",
]


def _xyz(name: str, value: Vec3Like) -> tuple[float, float, float]:
    if isinstance(value, np.ndarray):
        value = value.tolist()  # far faster than float() on numpy scalars
    try:
        x, y, z = value
        x, y, z = float(x), float(y), float(z)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a 3-vector, got {value!r}") from None
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise InputError(f"{name} must be finite, got {value!r}")
    return x, y, z


def _unit(name: str, value: Vec3Like) -> tuple[float, float, float]:
    x, y, z = _xyz(name, value)
    norm = math.sqrt(x * x + y * y + z * z)
    if norm == 0.0:
        raise InputError(f"{name} must be a non-zero vector")
    return x / norm, y / norm, z / norm


def _check_weights(spacing_m: float, w_prox: float, w_dist: float, w_plane: float) -> None:
    if not (math.isfinite(spacing_m) and spacing_m >= 0.0):
        raise InputError(f"marker spacing_m must be finite and >= 0, got {spacing_m!r}")
    if not (math.isfinite(w_prox) and w_prox > 0.0):
        raise InputError(f"filter weight w_prox must be positive and finite, got {w_prox!r}")
    for name, w in (("w_dist", w_dist), ("w_plane", w_plane)):
        if not (math.isfinite(w) and w >= 0.0):
            raise InputError(f"filter weight {name} must be finite and >= 0, got {w!r}")


@dataclass(frozen=True)
class EstimatorConfig:
    """Parameters of the marker filter and the pose from tags (paper values as defaults).

    Attributes:
        spacing_m: distance between the two marker centres on a brick (the paper's d = 17.5 cm).
        w_prox, w_dist, w_plane: weights of the filter's proximity, distance and planarity terms.
        up: normal of the plane the marker-to-marker vector lies in; also the axis yaw is measured about. In the
            camera frame with the camera looking down at the bricks this is the optical axis (0, 0, 1).

    Raises:
        InputError: a negative or non-finite value, ``w_prox <= 0`` or a zero ``up``.
    """

    spacing_m: float = 0.175
    w_prox: float = 2.0
    w_dist: float = 1.0
    w_plane: float = 1.0
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        _check_weights(self.spacing_m, self.w_prox, self.w_dist, self.w_plane)
        object.__setattr__(self, "up", _unit("up", self.up))


def _perpendicular(nx: float, ny: float, nz: float) -> tuple[float, float, float]:
    """A unit vector orthogonal to the unit vector n (deterministic)."""
    # Cross n with the coordinate axis least aligned with it.
    ax, ay, az = abs(nx), abs(ny), abs(nz)
    if ax <= ay and ax <= az:
        px, py, pz = 0.0, nz, -ny  # n x e_x = (0, nz, -ny)
    elif ay <= az:
        px, py, pz = -nz, 0.0, nx  # e_y x n
    else:
        px, py, pz = ny, -nx, 0.0  # n x e_z
    norm = math.sqrt(px * px + py * py + pz * pz)
    return px / norm, py / norm, pz / norm


def _solve_difference(
    q1: float, q2: float, spacing: float, a: float, b: float, c: float
) -> tuple[float, float]:
    """Global minimiser of ``a|x - q|^2 + b(|x| - s)^2 + c x2^2`` over x in R^2, q = (q1 >= 0, q2).

    Write the cost as a strictly convex quadratic minus ``2 b s |x|``; with ``-|x| = min_{|e|=1} -e.x`` the
    problem becomes ``max_{|e|=1} (a q + k e)^T H^-1 (a q + k e)``, ``k = b s``, ``H = diag(a+b, a+b+c)``: a
    trust-region subproblem on the unit circle. Its global solution is ``e_i = alpha_i / (nu - h_i)`` with
    ``h_i = 1/H_ii``, ``alpha_i = a h_i q_i / k`` and the unique ``nu >= h_1 = max h_i`` with ``|e| = 1``;
    then ``x = H^-1 (a q + k e)``. With ``delta = nu - h_1`` and ``g = h_1 - h_2 >= 0`` the secular function
    ``1/|e(delta)| - 1`` is concave and increasing, so Newton from ``delta = 0`` converges monotonically.
    """
    h1 = 1.0 / (a + b)
    h2 = 1.0 / (a + b + c)
    k = b * spacing
    if k == 0.0:
        return a * h1 * q1, a * h2 * q2
    al1 = a * h1 * q1 / k
    al2 = a * h2 * q2 / k
    g = h1 - h2
    if max(al1, abs(al2)) > 1e100:
        # Tiny b*s against the data: nu ~ |alpha| >> h, so e is the direction of alpha to within h/|alpha|.
        scale = math.hypot(al1 * 1e-100, al2 * 1e-100)
        e1, e2 = al1 * 1e-100 / scale, al2 * 1e-100 / scale
    elif al1 > 0.0:
        # Newton on f(delta) = 1/|e| - 1, f(0) = -1, f'(0) = 1/al1.
        delta = al1
        for _ in range(60):
            e1 = al1 / delta
            dg = delta + g
            e2 = al2 / dg
            norm2 = e1 * e1 + e2 * e2
            norm = math.sqrt(norm2)
            f = 1.0 / norm - 1.0
            if f >= 0.0:  # iterates approach the root from the left; f >= 0 only at the root (rounding)
                break
            slope = (e1 * e1 / delta + e2 * e2 / dg) / (norm2 * norm)
            step = f / slope
            delta -= step
            if -step <= 1e-15 * delta:
                break
        e1 = al1 / delta
        e2 = al2 / (delta + g)
    elif abs(al2) > g:
        e1, e2 = 0.0, math.copysign(1.0, al2)
    else:
        # The "hard case": d_meas is along n (or a = 0); the in-plane direction of d is arbitrary.
        e2 = al2 / g if g > 0.0 else 0.0
        e1 = math.sqrt(max(0.0, 1.0 - e2 * e2))
    return h1 * (a * q1 + k * e1), h2 * (a * q2 + k * e2)


def refine_markers(
    p1: Vec3Like,
    p2: Vec3Like,
    spacing_m: float,
    w_prox: float = 2.0,
    w_dist: float = 1.0,
    w_plane: float = 1.0,
    up: Vec3Like = (0.0, 0.0, 1.0),
) -> tuple[np.ndarray, np.ndarray]:
    """Refined marker positions minimising the paper's filter cost J (global minimum, closed form + Newton).

    Args:
        p1, p2: measured marker centres (m), marker 2k and marker 2k+1.
        spacing_m: the known distance between them (m).
        w_prox, w_dist, w_plane: weights of proximity, distance and planarity (``w_prox > 0``).
        up: the plane normal n (any non-zero length).

    Returns:
        ``(p1_hat, p2_hat)``, each shape (3,). Their midpoint is the measured midpoint.

    Raises:
        InputError: non-finite or malformed inputs, negative weights or spacing.
    """
    x1, y1, z1 = _xyz("p1", p1)
    x2, y2, z2 = _xyz("p2", p2)
    spacing, w_prox, w_dist, w_plane = float(spacing_m), float(w_prox), float(w_dist), float(w_plane)
    _check_weights(spacing, w_prox, w_dist, w_plane)
    nx, ny, nz = _unit("up", up)
    mx, my, mz = (x1 + x2) / 2.0, (y1 + y2) / 2.0, (z1 + z2) / 2.0
    qx, qy, qz = x1 - x2, y1 - y2, z1 - z2
    qn = qx * nx + qy * ny + qz * nz
    ux, uy, uz = qx - qn * nx, qy - qn * ny, qz - qn * nz
    qu = math.sqrt(ux * ux + uy * uy + uz * uz)
    # q (nearly) along n leaves u as rounding noise, whose direction is arbitrary and need not be perpendicular
    # to n: take a true perpendicular then (every one is as good, by symmetry about n) and treat qu as 0
    if qu > _PARALLEL_TOL * math.sqrt(qx * qx + qy * qy + qz * qz):
        ex, ey, ez = ux / qu, uy / qu, uz / qu
    else:
        qu = 0.0
        ex, ey, ez = _perpendicular(nx, ny, nz)
    along, normal = _solve_difference(qu, qn, spacing, w_prox / 2.0, w_dist, w_plane)
    hx = (along * ex + normal * nx) / 2.0
    hy = (along * ey + normal * ny) / 2.0
    hz = (along * ez + normal * nz) / 2.0
    return np.array([mx + hx, my + hy, mz + hz]), np.array([mx - hx, my - hy, mz - hz])


def marker_cost(
    p1_hat: Vec3Like,
    p2_hat: Vec3Like,
    p1: Vec3Like,
    p2: Vec3Like,
    spacing_m: float,
    w_prox: float = 2.0,
    w_dist: float = 1.0,
    w_plane: float = 1.0,
    up: Vec3Like = (0.0, 0.0, 1.0),
) -> float:
    """The paper's filter cost J of candidate positions ``(p1_hat, p2_hat)`` for measurements ``(p1, p2)``."""
    a, b = np.asarray(p1_hat, dtype=float), np.asarray(p2_hat, dtype=float)
    n = np.asarray(up, dtype=float)
    n = n / np.linalg.norm(n)
    d = a - b
    prox = float(
        np.sum((a - np.asarray(p1, dtype=float)) ** 2) + np.sum((b - np.asarray(p2, dtype=float)) ** 2)
    )
    return w_prox * prox + w_dist * (float(np.linalg.norm(d)) - spacing_m) ** 2 + w_plane * float(d @ n) ** 2


def refine_markers_bfgs(
    p1: Vec3Like,
    p2: Vec3Like,
    spacing_m: float,
    w_prox: float = 2.0,
    w_dist: float = 1.0,
    w_plane: float = 1.0,
    up: Vec3Like = (0.0, 0.0, 1.0),
    *,
    fallback: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's method, kept as the reference: scipy BFGS (numerical gradients) from the raw detections.

    With ``fallback`` (the paper's rule) the raw detections are returned when BFGS reports failure; without it,
    BFGS's last iterate (often the minimum despite a "precision loss" status). Used by the tests and by
    benchmarks/bench_filter.py; use :func:`refine_markers` in real code.
    """
    from scipy.optimize import minimize

    m1, m2 = np.asarray(p1, dtype=float), np.asarray(p2, dtype=float)
    n = np.asarray(up, dtype=float)
    n = n / np.linalg.norm(n)

    def cost(x: np.ndarray) -> float:
        a, b = x[:3], x[3:]
        d = a - b
        return float(
            w_prox * (np.sum((a - m1) ** 2) + np.sum((b - m2) ** 2))
            + w_dist * (np.linalg.norm(d) - spacing_m) ** 2
            + w_plane * (d @ n) ** 2
        )

    res = minimize(cost, np.concatenate([m1, m2]), method="BFGS")
    if (fallback and not res.success) or not np.all(np.isfinite(res.x)):
        return m1.copy(), m2.copy()
    return res.x[:3].copy(), res.x[3:].copy()


def yaw_about_rad(direction: Vec3Like, up: Vec3Like = (0.0, 0.0, 1.0)) -> float:
    """Angle of ``direction`` projected on the plane orthogonal to ``up``, measured like atan2(y, x) about ``up``.

    The plane's reference axes are the x and y axes rotated by the smallest rotation taking z onto ``up`` (a half
    turn about x when ``up`` is -z), so for ``up = (0, 0, 1)`` this is exactly ``atan2(direction_y, direction_x)``.
    Same convention as :func:`masonry.perception.aruco.yaw_about_rad`.
    """
    ux, uy, uz = _unit("up", up)
    vx, vy, vz = _xyz("direction", direction)
    if uz < -1.0 + 1e-12:
        return math.atan2(-vy, vx)
    # Rodrigues with k = z x u = (-uy, ux, 0): R = I + [k]x + [k]x^2 / (1 + uz); local = R^T v.
    # 1 / (1 + uz), computed without cancellation when up is close to -z (1 - uz^2 = ux^2 + uy^2).
    s = (1.0 - uz) / (ux * ux + uy * uy) if uz < 0.0 else 1.0 / (1.0 + uz)
    # Columns of R: e1 = R x, e2 = R y.
    e1 = (1.0 - ux * ux * s, -ux * uy * s, -ux)
    e2 = (-ux * uy * s, 1.0 - uy * uy * s, -uy)
    lx = e1[0] * vx + e1[1] * vy + e1[2] * vz
    ly = e2[0] * vx + e2[1] * vy + e2[2] * vz
    return math.atan2(ly, lx)


def estimate_brick_pose(
    tag1: TagPose | None,
    tag2: TagPose | None,
    config: EstimatorConfig | None = None,
) -> BrickEstimate | None:
    """Top-face centre and yaw of one brick from its marker poses (the paper's Algorithm "Estimate Brick Pose").

    ``tag1`` is marker 2k (at +spacing/2 along the brick's +x axis), ``tag2`` marker 2k+1 (at -spacing/2); the
    roles are taken from the marker ids, so a swapped call gives the same answer.

    - both tags: markers refined by :func:`refine_markers`, centre = midpoint, yaw = angle of p1^ - p2^ about up;
    - one tag: centre = tag centre -/+ spacing/2 along the tag's x axis (the brick's +x axis; exact in 3-D even
      when the brick is tilted), yaw = angle of the tag's x axis about up (the paper's correction Delta is 0 with
      this layout);
    - none: ``None``.

    Returns:
        A :class:`BrickEstimate` in the frame of the tag poses, or ``None`` without tags.

    Raises:
        PerceptionError: two tags that are not the two markers of one brick.
    """
    cfg = config if config is not None else EstimatorConfig()
    tags = [t for t in (tag1, tag2) if t is not None]
    if not tags:
        return None
    if len(tags) == 2:
        ids = sorted((tags[0].marker_id, tags[1].marker_id))
        if ids[0] % 2 != 0 or ids[1] != ids[0] + 1:
            raise PerceptionError(
                f"markers {ids[0]} and {ids[1]} are not the two markers 2k, 2k+1 of one brick"
            )
        plus, minus = (tags[0], tags[1]) if tags[0].marker_id == ids[0] else (tags[1], tags[0])
        p1_hat, p2_hat = refine_markers(
            plus.position_m, minus.position_m, cfg.spacing_m, cfg.w_prox, cfg.w_dist, cfg.w_plane, cfg.up
        )
        center = (p1_hat + p2_hat) / 2.0
        yaw = yaw_about_rad(p1_hat - p2_hat, cfg.up)
        return BrickEstimate(ids[0] // 2, center, yaw, (ids[0], ids[1]))
    tag = tags[0]
    px, py, pz = _xyz("tag position_m", tag.position_m)
    try:
        rotation = np.asarray(tag.R_cam_marker, dtype=float)
        ax, ay, az = (float(v) for v in rotation[:, 0].tolist())
    except (TypeError, ValueError, IndexError):
        raise PerceptionError(f"marker {tag.marker_id} has an invalid rotation") from None
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    if not (math.isfinite(norm) and norm > 0.0):
        raise PerceptionError(f"marker {tag.marker_id} has an invalid rotation")
    # Marker 2k sits at +spacing/2 along the brick's +x, so the centre is behind it; marker 2k+1 the other way.
    offset = (-1.0 if tag.marker_id % 2 == 0 else 1.0) * cfg.spacing_m / 2.0 / norm
    center = np.array([px + offset * ax, py + offset * ay, pz + offset * az])
    return BrickEstimate(tag.marker_id // 2, center, yaw_about_rad((ax, ay, az), cfg.up), (tag.marker_id,))


class PoseWindow:
    """Moving window over the last ``size`` estimates of one brick: mean pose and the paper's confidence.

    ``confidence() = 1 - min(1, sigma_max / sigma_tol_m)`` with ``sigma_max = max(sigma_x, sigma_y)``, the sample
    standard deviations (ddof = 1) of the centres in the window; yaw is averaged on the circle.

    Raises:
        InputError: ``size < 2`` or a non-positive ``sigma_tol_m``.
    """

    def __init__(self, size: int = 30, sigma_tol_m: float = 0.04) -> None:
        if int(size) != size or size < 2:
            raise InputError(f"pose window size must be an integer >= 2, got {size!r}")
        if not (math.isfinite(sigma_tol_m) and sigma_tol_m > 0.0):
            raise InputError(f"pose window sigma_tol_m must be positive, got {sigma_tol_m!r}")
        self.size = int(size)
        self.sigma_tol_m = float(sigma_tol_m)
        self._centers: deque[tuple[float, float, float]] = deque(maxlen=self.size)
        self._yaws: deque[float] = deque(maxlen=self.size)

    @property
    def count(self) -> int:
        """Number of estimates in the window (at most ``size``)."""
        return len(self._centers)

    def __len__(self) -> int:
        return len(self._centers)

    def add(self, center_m: Vec3Like, yaw_rad: float) -> None:
        """Push one estimate (the oldest drops out once the window is full)."""
        yaw = float(yaw_rad)
        if not math.isfinite(yaw):
            raise InputError(f"yaw_rad must be finite, got {yaw_rad!r}")
        self._centers.append(_xyz("center_m", center_m))
        self._yaws.append(yaw)

    def clear(self) -> None:
        """Forget every estimate (e.g. after the brick moved)."""
        self._centers.clear()
        self._yaws.clear()

    def mean(self) -> tuple[np.ndarray, float]:
        """Mean centre (3,) and circular-mean yaw in [-pi, pi].

        Raises:
            PerceptionError: the window is empty.
        """
        if not self._centers:
            raise PerceptionError("no brick estimate in the window yet")
        center = np.mean(np.array(self._centers), axis=0)
        yaw = math.atan2(sum(math.sin(y) for y in self._yaws), sum(math.cos(y) for y in self._yaws))
        return center, yaw

    def confidence(self) -> float | None:
        """The paper's C in [0, 1], or ``None`` with fewer than two estimates."""
        if len(self._centers) < 2:
            return None
        centers = np.array(self._centers)
        sigma = np.std(centers[:, :2], axis=0, ddof=1)
        return 1.0 - min(1.0, float(np.max(sigma)) / self.sigma_tol_m)

    def confident(self, threshold: float = C_TH) -> bool:
        """Whether the window's confidence has reached ``threshold`` (the paper's C_th)."""
        c = self.confidence()
        return c is not None and c >= threshold
