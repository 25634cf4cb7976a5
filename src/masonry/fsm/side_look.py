"""Look at the wall from the side (issue 30): a drop-off whose supports the carried brick hides is approached from
where the camera sees them.

The wall alignment (:mod:`masonry.fsm.wall_align`) cancels the GNSS wander only while a brick of the wall is in
the camera's view. A tower's next brick stands on one brick, right under the one carried: seen from above the
drop-off the carried brick hides it at every height (its shadow from the camera, 10 cm beside the rod, covers the
drop-off), so the descent was flown on the offset last measured, seconds before the release, or on GNSS. The
``px4`` wander moves on by about 12 mm per axis in 1 s and 30 mm in 3 s (rms, ``benchmarks/bench_as_built.py
--wander``): an offset is only as good as it is recent.

:func:`look_offset_m` finds the smallest horizontal displacement of the drop-off from which a whole marker of a
support (a brick the new one stands on) is inside the image and outside the carried brick's shadow, at the
alignment height and at the pre-release height (the carried brick ``PRE_RELEASE_GAP_M`` above the support). The
brick UAV then aligns and descends displaced so (the support in view all the way down, the offset tracked up to
then) and flies the last short leg to the drop-off in ``FINAL_LEG_S`` on the offset last measured (0.3-0.4 s
old at the release). Where a support's marker is in view at the release even 10 cm off its design (not covered
by a brick of the course), or no displacement keeps the carried brick's way clear of the course's other bricks,
nothing changes. Markers under a brick of the drop-off's course count as covered (whether it is built yet, the
UAV does not know).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from masonry.geometry import rot_z
from masonry.perception.types import CameraIntrinsics
from masonry.segments import point_segment_m

if TYPE_CHECKING:
    from masonry.fsm.brick import BrickUav
    from masonry.ports import Telemetry

__all__ = [
    "ACQUIRE_SPREAD_M",
    "FINAL_LEG_S",
    "LAG_STEP_S",
    "LEG_REST_WAIT_S",
    "PASS_OVERSHOOT_M",
    "PRE_RELEASE_GAP_M",
    "TRACK_SPREAD_M",
    "LookScene",
    "SideLook",
    "heading_flip_rad",
    "last_leg_lag_s",
    "look_offset_m",
    "marker_in_view",
    "scene_of",
]

#: The carried brick's bottom this far above its support at the end of the displaced descent.
PRE_RELEASE_GAP_M = 0.03
#: How far (m) a support may be from where the design and the position put it when the alignment hover first
#: looks for it (a first course placed on GNSS and the wander since: about 6 cm each per axis), and once tracked.
ACQUIRE_SPREAD_M = 0.10
TRACK_SPREAD_M = 0.04
#: The last leg, displaced point to drop-off (about 10-15 cm): short, the offset held is that old at the release.
FINAL_LEG_S = 1.2
#: A pass of the last leg this far (m) past its drop-off along the leg, or gone stale this far short of it, moves the
#: next pass's lag by ``LAG_STEP_S`` (:meth:`SideLook.leg_lag_s`): twice r_pl, past the airframe's wander in a pass.
PASS_OVERSHOOT_M = 0.03
LAG_STEP_S = 0.1
#: The first pass waits at most this long (s) past the displaced descent's end for the UAV to rest there (a look's
#: ``release_gate.RELOOK_WAIT_S``).
LEG_REST_WAIT_S = 3.0
#: Displacements tried: every 22.5 degrees in the body frame, 4 to 35 cm.
_DIRECTIONS = 16
_DISTANCES_M = tuple(0.04 + 0.01 * i for i in range(47))
#: A marker corner nearer the image's edge than this is not counted on (pixels).
_EDGE_PX = 8.0
#: Bricks side by side in a course touch: closer than this (m) past touching is an overlap.
_TOUCH_M = 0.002


@dataclass(frozen=True, eq=False)
class LookScene:
    """What the brick UAV knows of a placement (world ENU, metres, radians).

    Attributes:
        drop_top_m: the drop-off's top-face centre (where the effector releases).
        body_yaw_rad: the UAV's heading at the drop-off.
        brick_yaw_rad: the carried brick's yaw (its design yaw).
        size_m: the carried brick's size (length, width, height).
        supports: the top-face centres of the bricks it stands on (their yaw taken as the brick's).
        others: the top-face centres of the other bricks of the wall near it (for the way clear).
        marker_size_m, marker_spacing_m: the markers on each top face.
        intrinsics: the camera's.
        T_body_cam: the camera's pose on the body (4x4).
        effector_body_m: the effector tip on the body (the rod hangs plumb).
        align_height_m: the effector's height above ``drop_top_m`` in the alignment hover.
        pads_m, pad_keep_off_m: the other UAVs' pads, and how far the body keeps from each on its way from the
            drop-off to the alignment hover (mission control reserves that way, and never near a landed UAV).
    """

    drop_top_m: tuple[float, float, float]
    body_yaw_rad: float
    brick_yaw_rad: float
    size_m: tuple[float, float, float]
    supports: tuple[tuple[float, float, float], ...]
    others: tuple[tuple[float, float, float], ...]
    marker_size_m: float
    marker_spacing_m: float
    intrinsics: CameraIntrinsics
    T_body_cam: np.ndarray
    effector_body_m: tuple[float, float, float]
    align_height_m: float
    pads_m: tuple[tuple[float, float], ...] = ()
    pad_keep_off_m: float = 0.0


def _marker_corners(
    top_m: Sequence[float], yaw_rad: float, spacing_m: float, size_m: float
) -> list[np.ndarray]:
    """The four corners (4, 3) of each of the two markers on a top face centred at ``top_m``."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    h = size_m / 2.0
    out = []
    for sign in (1.0, -1.0):
        mx = top_m[0] + sign * c * spacing_m / 2.0
        my = top_m[1] + sign * s * spacing_m / 2.0
        out.append(
            np.array(
                [(mx + h * (c * dx - s * dy), my + h * (s * dx + c * dy), top_m[2]) for dx, dy in _SQUARE],
                dtype=float,
            )
        )
    return out


_SQUARE = ((-1.0, 1.0), (1.0, 1.0), (1.0, -1.0), (-1.0, -1.0))


def marker_in_view(
    corners_m: np.ndarray,
    camera_m: np.ndarray,
    R_wc: np.ndarray,
    intrinsics: CameraIntrinsics,
    occluder_top_m: Sequence[float],
    occluder_yaw_rad: float,
    occluder_half_m: tuple[float, float],
) -> bool:
    """Whether a whole marker (its corners, world) is inside the image of a camera at ``camera_m`` (rotation
    ``R_wc``) and none of its corners is behind the carried brick's top face (a rectangle of half sizes
    ``occluder_half_m`` centred at ``occluder_top_m``, turned ``occluder_yaw_rad``)."""
    q = (corners_m - camera_m) @ R_wc
    if np.any(q[:, 2] <= 0.05):
        return False
    u = intrinsics.fx * q[:, 0] / q[:, 2] + intrinsics.cx
    v = intrinsics.fy * q[:, 1] / q[:, 2] + intrinsics.cy
    if np.any((u < _EDGE_PX) | (u > intrinsics.width_px - 1 - _EDGE_PX)):
        return False
    if np.any((v < _EDGE_PX) | (v > intrinsics.height_px - 1 - _EDGE_PX)):
        return False
    top = occluder_top_m[2]
    if camera_m[2] <= top:
        return True
    c, s = math.cos(occluder_yaw_rad), math.sin(occluder_yaw_rad)
    for p in corners_m:
        if p[2] >= top:
            continue
        t = (top - camera_m[2]) / (p[2] - camera_m[2])
        dx = camera_m[0] + t * (p[0] - camera_m[0]) - occluder_top_m[0]
        dy = camera_m[1] + t * (p[1] - camera_m[1]) - occluder_top_m[1]
        along, across = c * dx + s * dy, -s * dx + c * dy
        if abs(along) <= occluder_half_m[0] and abs(across) <= occluder_half_m[1]:
            return False
    return True


def _support_seen(
    scene: LookScene, displacement_m: np.ndarray, height_m: float, spread_m: float = 0.0
) -> bool:
    """A whole support marker is in view with the effector at the drop-off + ``displacement_m``, ``height_m`` up;
    with ``spread_m``, also with the supports that far off their design in any of 8 directions."""
    effector = np.asarray(scene.drop_top_m, dtype=float) + np.array(
        [displacement_m[0], displacement_m[1], height_m]
    )
    R_wb = rot_z(scene.body_yaw_rad)
    body = effector - R_wb @ np.asarray(scene.effector_body_m, dtype=float)
    T = np.asarray(scene.T_body_cam, dtype=float)
    camera = body + R_wb @ T[:3, 3]
    R_wc = R_wb @ T[:3, :3]
    half = (scene.size_m[0] / 2.0, scene.size_m[1] / 2.0)
    shifts = [(0.0, 0.0)]
    if spread_m > 0.0:
        shifts += [
            (spread_m * math.cos(a), spread_m * math.sin(a)) for a in np.linspace(0.0, 2 * math.pi, 9)[:-1]
        ]
    for sx, sy in shifts:
        if not any(
            not _covered(scene, corners.mean(axis=0))
            and marker_in_view(corners, camera, R_wc, scene.intrinsics, effector, scene.brick_yaw_rad, half)
            for support in scene.supports
            for corners in _marker_corners(
                (support[0] + sx, support[1] + sy, support[2]),
                scene.brick_yaw_rad,
                scene.marker_spacing_m,
                scene.marker_size_m,
            )
        ):
            return False
    return True


def _in_brick_frame(scene: LookScene, dx_m: float, dy_m: float) -> tuple[float, float]:
    """A horizontal offset along and across the brick (its yaw: the wall's bricks share it)."""
    c, s = math.cos(scene.brick_yaw_rad), math.sin(scene.brick_yaw_rad)
    return c * dx_m + s * dy_m, -s * dx_m + c * dy_m


def _covered(scene: LookScene, point_m: Sequence[float]) -> bool:
    """A brick of the drop-off's course (built or not yet: the UAV does not know) rests on ``point_m``."""
    half_l, half_w = scene.size_m[0] / 2.0, scene.size_m[1] / 2.0
    for other in scene.others:
        if abs(other[2] - scene.drop_top_m[2]) > 1e-3:
            continue
        along, across = _in_brick_frame(scene, point_m[0] - other[0], point_m[1] - other[1])
        if abs(along) < half_l and abs(across) < half_w:
            return True
    return False


def _way_clear(scene: LookScene, displacement_m: np.ndarray) -> bool:
    """The carried brick, moved from the drop-off by up to ``displacement_m``, overlaps no other brick of the
    drop-off's course or above (but those standing on the new brick: not built yet)."""
    x0, y0, z0 = scene.drop_top_m
    length, width = scene.size_m[0] - _TOUCH_M, scene.size_m[1] - _TOUCH_M
    for other in scene.others:
        if other[2] <= z0 - scene.size_m[2] + 1e-3:
            continue
        if other[2] > z0 + 1e-3 and math.hypot(other[0] - x0, other[1] - y0) < 0.99 * scene.size_m[0]:
            continue  # it stands on the drop-off's brick: not built yet
        for f in np.linspace(0.0, 1.0, 11):
            along, across = _in_brick_frame(
                scene, other[0] - x0 - f * displacement_m[0], other[1] - y0 - f * displacement_m[1]
            )
            if abs(along) < length and abs(across) < width:
                return False
    return True


def _off_pads(scene: LookScene, displacement_m: np.ndarray) -> bool:
    """The body's way from over the drop-off to ``displacement_m`` off it keeps ``pad_keep_off_m`` from every other
    UAV's pad: the zone the brick UAV asks for spans it, and one that near a landed UAV is never granted (issue 27:
    ``bench_layouts --compact --faults --policy nearest`` seed 5543, a hover 0.5 m towards a pad 1.1 m off)."""
    if not scene.pads_m:
        return True
    R_wb = rot_z(scene.body_yaw_rad)
    body = np.asarray(scene.drop_top_m, dtype=float) - R_wb @ np.asarray(scene.effector_body_m, dtype=float)
    a = (float(body[0]), float(body[1]))
    b = (a[0] + float(displacement_m[0]), a[1] + float(displacement_m[1]))
    return all(point_segment_m(p, a, b) >= scene.pad_keep_off_m for p in scene.pads_m)


def look_offset_m(scene: LookScene) -> tuple[np.ndarray, np.ndarray] | None:
    """The horizontal displacements (world, m) from the drop-off of the alignment hover and of the pre-release
    point: a support's marker in the camera's view all the way down the straight descent between them (from the
    hover with the support up to ``ACQUIRE_SPREAD_M`` off its design: the wall's offset is not known yet there;
    then the alignment keeps it where the design puts it, give or take ``TRACK_SPREAD_M``); the pre-release one the
    shortest. None: no support, one already in view at the release, none found, or the way not clear."""
    if not scene.supports:
        return None
    # one in view at the release, even with the supports as far off as the hover may find them: as before
    if _support_seen(scene, np.zeros(2), 0.0, ACQUIRE_SPREAD_M):
        return None
    for spread in (ACQUIRE_SPREAD_M, ACQUIRE_SPREAD_M / 2.0, 0.0):  # the surest first
        found = _look(scene, spread)
        if found is not None:
            return found
    return None


def _look(scene: LookScene, acquire_spread_m: float) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`look_offset_m` with the support up to ``acquire_spread_m`` off where the hover looks for it."""
    pre, high = PRE_RELEASE_GAP_M, scene.align_height_m
    R_wb = rot_z(scene.body_yaw_rad)[:2, :2]
    best: tuple[float, float, np.ndarray, np.ndarray] | None = None
    for k in range(_DIRECTIONS):
        a = 2.0 * math.pi * k / _DIRECTIONS
        unit = R_wb @ np.array([math.cos(a), math.sin(a)])
        near = next((d for d in _DISTANCES_M if _support_seen(scene, d * unit, pre, TRACK_SPREAD_M)), None)
        if near is None or (best is not None and near > best[0]):
            continue
        far = next(
            (d for d in _DISTANCES_M if d >= near and _support_seen(scene, d * unit, high, acquire_spread_m)),
            None,
        )
        if far is None or (best is not None and (near, far) >= best[:2]):
            continue
        if not all(
            _support_seen(scene, (near + f * (far - near)) * unit, pre + f * (high - pre), TRACK_SPREAD_M)
            for f in (0.25, 0.5, 0.75)
        ):
            continue
        if _way_clear(scene, near * unit) and _way_clear(scene, far * unit) and _off_pads(scene, far * unit):
            best = (near, far, near * unit, far * unit)
    if best is None:
        return None
    return np.array([best[3][0], best[3][1], 0.0]), np.array([best[2][0], best[2][1], 0.0])


class SideLook:
    """The brick UAV's side look for one placement: the displacement planned (None: none) and the leg flown; and,
    over its placements, the last leg's lag learnt from its passes (:meth:`leg_lag_s`)."""

    def __init__(self) -> None:
        self.offset_m: np.ndarray | None = None  # the pre-release point's displacement
        self.final = False
        #: the last leg's feed-forward lag (s) learnt from its passes (None: ``UavConfig.last_leg_lag_s``)
        self.lag_s: float | None = None
        #: the pass in hand: the farthest (m) past the drop-off along the leg (None: no pass flown yet)
        self._past_m: float | None = None
        #: the pass in hand had a tick inside r_pl on a fresh sighting passed over (``ReleaseGate.wide``)
        self.on_time = False

    def plan(self, uav: BrickUav) -> np.ndarray:
        """A new alignment above the drop-off: the displacement of its hover (zero without a side look; never
        without ``align_on_wall`` and ``side_look``)."""
        self.offset_m, self.final, self._past_m, self.on_time = None, False, None, False
        cfg = uav.config
        if not (uav.on_wall and cfg.side_look and cfg.wall):
            return np.zeros(3)
        found = look_offset_m(scene_of(uav))
        if found is None:
            return np.zeros(3)
        self.offset_m = found[1]
        return found[0]

    def descent_target_m(self, effector_target_m: np.ndarray) -> np.ndarray:
        """Where the descent takes the effector: the pre-release point with a side look, else the drop-off."""
        if self.offset_m is None:
            return effector_target_m
        return np.asarray(
            effector_target_m + self.offset_m + np.array([0.0, 0.0, PRE_RELEASE_GAP_M]), dtype=float
        )

    def leg_due(self, uav: BrickUav) -> bool:
        """The displaced descent is over and its last leg not yet flown."""
        return self.offset_m is not None and not self.final and uav._now_s >= uav.nav.end_s

    def step(self, uav: BrickUav, yaw_rad: float) -> None:
        """The displaced descent over: fly the last leg to the drop-off (once)."""
        if self.offset_m is None or self.final or uav._now_s < uav.nav.end_s:
            return
        tel = uav._tel
        assert tel is not None
        # from rest at the pre-release point, as a look's leg (masonry.fsm.release_gate), for at most LEG_REST_WAIT_S:
        # on the real PX4 a first pass begun from the displaced descent's swing (0.15 m/s across the leg) swung 12 cm
        # wide, came back through the drop-off at 0.42 m/s and let go at r_pl's edge, 20.4 mm off as built (branch
        # px4case35); the support is in view there, so the wait keeps the sighting fresh
        if uav._now_s < uav.nav.end_s + LEG_REST_WAIT_S and not uav.nav.rests_at(tel, uav.nav.target_m):
            return
        self.final = True
        body = uav.effector.body_target(uav.attempt.place_effector_target_m, yaw_rad)
        uav._fly_to(tel, body, FINAL_LEG_S, yaw_rad, lag_s=self.leg_lag_s(uav))

    def track(self, uav: BrickUav, tel: Telemetry, looking: bool) -> None:
        """One tick of the descent: on the last leg's pass (not a look back up), how far past the drop-off the
        effector has come along the leg (the leg runs from the pre-release point against ``offset_m``)."""
        if self.offset_m is None or not self.final or looking or self._past_m is None:
            return
        away = np.asarray(self.offset_m, dtype=float)[:2]
        norm = float(np.hypot(*away))
        if norm < 1e-9:
            return
        error = (
            np.asarray(uav.effector.position(tel), dtype=float)[:2]
            - np.asarray(uav.attempt.place_effector_target_m, dtype=float)[:2]
        )
        self._past_m = max(self._past_m, -float(error @ away) / norm)

    def leg_lag_s(self, uav: BrickUav) -> float | None:
        """The lag of a new pass of the last leg (:func:`last_leg_lag_s`, as learnt from the passes before it).

        The pass before it, if one was flown in this placement, moves the lag by ``LAG_STEP_S``: down where it
        ran more than ``PASS_OVERSHOOT_M`` past the drop-off, back up (never past the configured lag) where it
        went stale more than that short of it. The configured lag was fitted on the ``px4`` model (25 % droop);
        the real PX4 v1.16 follows the feed-forward's velocity in full after its dead time, and its passes on
        0.5 s ran 4-12 cm past the drop-off (median 6) at up to twice the leg's speed, so a pass rarely had a tick
        inside r_pl while the support's sighting was fresh: 20 looks back up a tower brick, 85-100 s a descent
        (tests/test_px4_sitl.py's case study, docs/performance/autopilots.md, branch ``px4case35``)."""
        base = last_leg_lag_s(uav)
        past, self._past_m = self._past_m, -math.inf
        on_time, self.on_time = self.on_time, False
        if base is None:
            return None
        lag = base if self.lag_s is None else min(self.lag_s, base)
        if on_time:  # it reached the drop-off in time (passed over wide): what it ran past after says nothing
            past = None
        if past is not None and past > PASS_OVERSHOOT_M:
            lag = max(0.0, lag - LAG_STEP_S)
        elif past is not None and math.isfinite(past) and past < -PASS_OVERSHOOT_M:
            lag = min(base, lag + LAG_STEP_S)
        self.lag_s = lag
        return lag


def last_leg_lag_s(uav: BrickUav) -> float | None:
    """The lag (s) of the last leg's acceleration feed-forward (``UavConfig.last_leg_lag_s``; None: the UAV's
    ``velocity_lag_s``). On the refitted ``px4`` model (0.25 s of dead time, a 0.15 s lag and 25 % droop) the
    default 0.3 s left the leg 5-8 cm short at its end; it then overshot, and came back past the wall's sighting's
    freshness (the towers' releases on 2-4 s old looks, docs/performance/as-built.md). Not in a wind (the
    placement flies kp 2 there, :mod:`masonry.fsm.wind_lean`): measured a draw on the 4 m/s towers and pyramid."""
    lag_s = uav.config.last_leg_lag_s
    return lag_s if lag_s > 0.0 and not uav.attempt.in_wind else None


def _beside_seen(scene: LookScene, beside_m: Sequence[tuple[float, float, float]]) -> bool:
    """A whole marker of a brick beside the drop-off in its course (top-face centres ``beside_m``) in the camera's
    view, outside the carried brick's shadow, with the effector right over the drop-off at it or at the first look
    point above it (the wall at its design)."""
    others = tuple(o for o in scene.others if all(math.dist(o, t) > 1e-6 for t in beside_m))
    look = replace(scene, supports=tuple(beside_m), others=others)
    return any(_support_seen(look, np.zeros(2), h) for h in (0.0, PRE_RELEASE_GAP_M + _FIRST_LOOK_M))


#: The first look point's height over the pre-release point (``release_gate.RELOOK_CLIMB_M``)
_FIRST_LOOK_M = 0.05


def heading_flip_rad(uav: BrickUav, heading_rad: float) -> float:
    """pi to place ``uav``'s first-course brick turned a half turn (the body at ``heading_rad`` + pi), else 0.

    A first-course drop-off beside bricks of its course, none of them in the camera's view at the release or the
    first look point at ``heading_rad``, one of them in view turned: the camera sits 10 cm beside the rod, and a
    neighbour on the far side is out of the image below about 13 cm and under the carried brick's shadow above (the
    px4 pyramid's B2 beside B1: no height from 0 to 40 cm showed a marker of B1; its release waited on sightings
    1-4 s old and failed seeds 15 and 19, and B2 lay 2-15 cm off B1 on 13 of the 18 other seeds;
    docs/performance/as-built.md, branch ``pyrseed33``). The brick is the same turned; its markers are estimated
    with their own orientation. Only with ``align_on_wall`` and ``side_look``."""
    cfg, task = uav.config, uav.brick_task
    if not (cfg.align_on_wall and cfg.side_look and cfg.wall):
        return 0.0
    bottom = task.position_m[2] - task.size_m[2] / 2.0
    top = bottom + task.size_m[2]
    beside, below = [], False
    for bid, t in cfg.wall:
        h = math.hypot(t[0] - task.position_m[0], t[1] - task.position_m[1])
        if bid == task.brick or h >= 1.01 * task.size_m[0]:
            continue
        if abs(t[2] - bottom) < 1e-3 and h < 0.99 * task.size_m[0]:
            below = True
        elif abs(t[2] - top) < 1e-3:
            beside.append((float(t[0]), float(t[1]), float(t[2])))
    if below or not beside:
        return 0.0
    if _beside_seen(scene_of(uav, heading_rad), beside):
        return 0.0
    return math.pi if _beside_seen(scene_of(uav, heading_rad + math.pi), beside) else 0.0


def scene_of(uav: BrickUav, body_yaw_rad: float | None = None) -> LookScene:
    """The placement in hand as :func:`look_offset_m` sees it (its design and the wall's, ``UavConfig.wall``), the
    body at ``body_yaw_rad`` (None: the placement's heading)."""
    cfg, task = uav.config, uav.brick_task
    top = uav._place_effector_target_m()
    drop = (float(top[0]), float(top[1]), float(top[2]))
    bottom = drop[2] - task.size_m[2]
    supports, others = [], []
    for bid, t in cfg.wall:
        if bid == task.brick:
            continue
        h = math.hypot(t[0] - drop[0], t[1] - drop[1])
        if abs(t[2] - bottom) < 1e-3 and h < 0.99 * task.size_m[0]:
            supports.append((float(t[0]), float(t[1]), float(t[2])))
        elif h < 1.0:
            others.append((float(t[0]), float(t[1]), float(t[2])))
    eff = uav.effector.offset_body_m
    return LookScene(
        drop_top_m=drop,
        body_yaw_rad=uav._place_yaw_rad() if body_yaw_rad is None else body_yaw_rad,
        brick_yaw_rad=task.yaw_rad,
        size_m=task.size_m,
        supports=tuple(supports),
        others=tuple(others),
        marker_size_m=cfg.markers.size_m,
        marker_spacing_m=cfg.markers.spacing_m,
        intrinsics=uav.camera.intrinsics,
        T_body_cam=uav._T_body_cam,
        effector_body_m=eff,
        align_height_m=uav._transit_altitude_m() + eff[2] - drop[2],
        pads_m=cfg.pads_m,
        pad_keep_off_m=cfg.pad_keep_off_m,
    )
