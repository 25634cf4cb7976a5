"""Placement by the wall's own markers (issue 30): the brick UAV aligns its drop-off on the bricks around it.

On GNSS (``px4``: EKF2's +-15 cm of slow wander) the drop-off flown on the absolute position misses by the wander:
the effector is placed at ``design + e(t)`` in the reported frame, ``design - e(t)`` in truth... relative to what
the wall really is. The bricks already on the wall (and the pre-placed ones) carry markers, and the camera sees
some of them while the UAV aligns above the drop-off and descends: each such brick k, estimated in the world frame
from the same telemetry the position loop closes on, sits at ``true_k + e(t)``. Its offset from its designed pose
(``UavConfig.wall``) is ``(true_k - design_k) + e(t)``: the wander plus how far brick k was built off. The mean of
these offsets over the bricks in view, added to the drop-off, makes the effector's target move with ``e(t)`` (the
wander cancels, as in :mod:`masonry.fsm.camera_align`) and with the bricks around it (the new brick keeps its
designed offsets to them). A brick farther than ``_REFERENCE_M`` from its design (one on the pallet, one on
another UAV's magnet) is no reference; with none in view the last offset stands. Where the one brick the new one stands on
(:func:`supports_of`) is in view, only it counts: a tower's third brick sees its support and the tower's first
brick, and a support built 12 cm off the one under it would otherwise pull the new brick half way back to the
design (the px4 towers, seed 4: 34.7 mm off its support; 3.5 mm with the supports only). Once that support has been
seen, a frame without it is no sighting (:func:`off_support`: another tower's brick alone, at its own as-built
place, put the drop-off 5-9 cm off). Bricks beside it in
its course are not preferred so (measured, the rotated bond's worst brick grew from 21.9 to 34.2 mm, seed 3), nor
one of two supports (a pyramid's brick: 11.6 -> 47.7 mm).

**Relative to the wall as it stands** (``UavConfig.wall_as_built``): a brick assignment carries the placed bricks'
deviations from their design relative to the wall (``BrickTask.wall_as_built``, :mod:`masonry.planner.wall_deviation`:
chained from the relative as-built poses, so without the position source's error). Each brick in view then counts
at its as-built place (:func:`wall_offset_m` less its deviation: the wander and the chain's common constant
remain), and the drop-off is the brick's design plus its placed neighbours' mean deviation (:func:`follow_m`:
supports and course neighbours, seen or not), pulled back toward the design by ``wall_pullback_m`` per course and
at most ``wall_follow_cap_m`` from it: a course end that sees only its course neighbour no longer inherits that
neighbour's offset from its supports (docs/state-machines.md, "Building relative to the wall as it stands").

:class:`WallAlign` is a :class:`~masonry.fsm.camera_align.CameraAlign` over the drop-off's top-face centre (the
same smoothing and deadband, its mean over the frames no older than ``release_fresh_s`` before the newest,
:func:`frames_span_s`: a fresh sighting is not averaged with frames seconds old); ``UavConfig.align_on_wall``
turns it on (the ``px4`` control preset does). A drop-off planned on the as-built poses gives way to it: the offset
is added to the brick's own design, not to the planned target (the bricks in view place it as the plan would,
measured now).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Set
from typing import TYPE_CHECKING

import numpy as np

from masonry.fsm.as_built import frame_tags, world_estimate
from masonry.fsm.camera_align import CameraAlign
from masonry.fsm.carried_look import CarriedLook
from masonry.fsm.place_taken import PLACE_TAKEN, taken_by
from masonry.fsm.wall_trend import WallTrend
from masonry.planner.as_built_plan import pulled_back

if TYPE_CHECKING:
    from masonry.fsm.brick import BrickUav
    from masonry.planner.tasks import BrickTask
    from masonry.ports import Telemetry

__all__ = [
    "LONE_SHIFT_M",
    "WallAlign",
    "drift_noise_mps_per_sqrt_s",
    "follow_in_view",
    "follow_m",
    "frames_span_s",
    "neighbours_of",
    "off_support",
    "supports_of",
    "wall_offset_m",
]

#: A brick seen farther than this from its design is not on the wall (a pallet, a magnet): no reference.
_REFERENCE_M = 0.5


def wall_offset_m(
    estimates: Mapping[int, np.ndarray],
    wall: Mapping[int, tuple[float, ...]],
    own: int,
    near: frozenset[int] = frozenset(),
    as_built: Mapping[int, tuple[float, float, float]] | None = None,
) -> np.ndarray | None:
    """The mean offset (world, m) of the bricks seen (``estimates``: brick id -> estimated top-face centre) from
    their designed top-face centres (``wall``) moved by their deviations relative to the wall (``as_built``;
    none: on their design), brick ``own`` and bricks off the wall left out, only those of ``near`` if one of them
    is seen; None: none."""
    offsets: dict[int, np.ndarray] = {}
    for bid, top in estimates.items():
        design = wall.get(bid)
        if bid == own or design is None:
            continue
        d = np.asarray(top, dtype=float) - np.asarray(design, dtype=float)
        if float(np.linalg.norm(d)) <= _REFERENCE_M:
            offsets[bid] = d - np.asarray((as_built or {}).get(bid, (0.0, 0.0, 0.0)), dtype=float)
    if not offsets:
        return None
    close = [d for bid, d in offsets.items() if bid in near]
    return np.asarray(np.mean(close or list(offsets.values()), axis=0), dtype=float)


def frames_span_s(release_fresh_s: float) -> float:
    """The wall alignment's target is the mean of its last frames no older than this (s) before the newest: the
    age of a sighting the release trusts (``UavConfig.release_fresh_s``; inf without one, the last five whatever
    their age). A neighbour that drops in and out of view leaves its last five frames seconds apart, and their mean
    the wander of those seconds: the px4 wall in 4 m/s let bricks go on a sighting 0.0 s old with three of the five
    frames 1.1-2.7 s older, the GNSS 20-25 mm/s on, the target 18-30 mm off its neighbour (rotated bond seed 0 B0,
    pyramid seed 9 B0; docs/performance/as-built.md, branch ``gust34``)."""
    return release_fresh_s if release_fresh_s > 0.0 else math.inf


def supports_of(
    wall: Mapping[int, tuple[float, ...]], own: int, size_m: tuple[float, float, float]
) -> frozenset[int]:
    """The bricks of ``wall`` (id -> designed top-face centre) brick ``own`` (of size ``size_m``) stands on: one
    course below, centres less than a brick's length apart horizontally."""
    top = wall.get(own)
    if top is None:
        return frozenset()
    return frozenset(
        bid
        for bid, t in wall.items()
        if bid != own
        and abs(top[2] - t[2] - size_m[2]) < 1e-3
        and float(np.hypot(t[0] - top[0], t[1] - top[1])) < 0.99 * size_m[0]
    )


def neighbours_of(
    wall: Mapping[int, tuple[float, ...]], own: int, size_m: tuple[float, float, float]
) -> frozenset[int]:
    """The bricks of ``wall`` brick ``own`` touches: its supports (:func:`supports_of`) and the bricks beside it
    in its course (centres at most a brick's length apart horizontally)."""
    top = wall.get(own)
    if top is None:
        return frozenset()
    beside = frozenset(
        bid
        for bid, t in wall.items()
        if bid != own
        and abs(top[2] - t[2]) < 1e-3
        and float(np.hypot(t[0] - top[0], t[1] - top[1])) <= 1.01 * size_m[0]
    )
    return beside | supports_of(wall, own, size_m)


def follow_m(
    neighbours: frozenset[int],
    as_built: Mapping[int, tuple[float, float, float]],
    pullback_m: float,
    cap_m: float,
) -> np.ndarray:
    """How far from its design (relative to the wall, m) a brick is placed: the mean deviation of its placed
    ``neighbours`` as built (``as_built``, relative to the wall), pulled back toward the design by ``pullback_m``
    horizontally and at most ``cap_m`` from it (:func:`~masonry.planner.as_built_plan.pulled_back`); zero with
    none known."""
    known = [as_built[b] for b in sorted(neighbours) if b in as_built]
    if not known:
        return np.zeros(3)
    mean = np.mean(np.asarray(known, dtype=float), axis=0)
    return np.asarray(pulled_back((float(mean[0]), float(mean[1]), float(mean[2])), pullback_m, cap_m))


def follow_in_view(follow_m: np.ndarray, seen_m: np.ndarray, cap_m: float) -> np.ndarray:
    """The drop-off's deviation from the design relative to the wall (m) given the bricks in view: ``follow_m``
    (its neighbours' mean as built, pulled back, not capped) moved to within ``cap_m`` of ``seen_m`` (the mean
    deviation of the bricks in view as they are counted), horizontally and vertically apart. The brick then
    lies at most ``cap_m`` off its designed offsets to the bricks it is aligned on, whatever the deviations say:
    a tower's brick aligned on its one support keeps to it (the pull-back off it), where the cap on ``follow_m``
    from the design set it ``|deviation| - cap`` off it (the px4 towers, seed 2: a support passed on 48 mm off,
    the brick let go 28 mm off it; docs/performance/as-built.md)."""
    d = np.asarray(follow_m, dtype=float) - np.asarray(seen_m, dtype=float)
    n = math.hypot(float(d[0]), float(d[1]))
    k = 1.0 if n <= cap_m else cap_m / n
    out = np.asarray(seen_m, dtype=float) + np.array(
        [d[0] * k, d[1] * k, min(max(float(d[2]), -cap_m), cap_m)]
    )
    return np.asarray(out, dtype=float)


def off_support(touching: frozenset[int], seen_ids: Set[int], in_view: Set[int]) -> bool:
    """A frame that shows bricks of the wall (``in_view``) but none of those the drop-off touches (``touching``:
    its one support and the bricks beside it in its course, :func:`neighbours_of`; empty on two supports), one of
    which has been seen in this placement (``seen_ids``): True, no sighting. Each brick counts at its own as-built
    place, and a tower's bricks are each seen alone (their as-built poses carry their looks' GNSS wander, 6 cm per
    axis): a frame of another tower only put the drop-off 5-9 cm off where its support puts it, and the mean of the
    last five frames 1-2 cm (the px4 towers in 4 m/s, seeds 0-9: 472 such frames; seed 2's B7 let go 27 mm off its
    support so, one such frame 0.8 s before the release; docs/performance/as-built.md, branch ``towers34``). Before
    the first sighting of a brick it touches the others count as before."""
    return bool(touching & seen_ids) and not touching & in_view


def drift_noise_mps_per_sqrt_s(configured: float, in_wind: bool, side_look: bool) -> float:
    """The drift filter's rate noise for this frame (:mod:`masonry.fsm.wall_trend`; 0: the straight line):
    ``configured`` (``UavConfig.wall_drift_mps_per_sqrt_s``) in calm air, and in a wind on the side look's descent
    only. Elsewhere in 4 m/s the filter failed px4 missions the straight line completes (the bond's seed 1, the
    pyramid's seed 0: a first-course brick put back after three descents, branch ``drift30``); on the side look's
    descent (a tower's brick, its support out of view for the last leg) it put the 4 m/s towers' targets 6.5 mm rms
    off against the line's 8.6 (docs/performance/as-built.md, branch ``towers34``)."""
    return configured if side_look or not in_wind else 0.0


#: A lone brick's target follows the carried brick's measured offset once it has moved this far (m).
LONE_SHIFT_M = 0.0005


class WallAlign:
    """The drop-off's target as the bricks around it place it (see the module docstring)."""

    def __init__(self) -> None:
        self.tracker = CameraAlign()
        self.carried = CarriedLook()  # (masonry.fsm.carried_look: the brick's offset on the magnet)
        self.trend = WallTrend(0.0)  # (masonry.fsm.wall_trend: the wander carried past the last sighting)
        self.design_m = np.zeros(3)
        self._wall: dict[int, tuple[float, ...]] | None = None
        self._near: frozenset[int] = frozenset()
        self._touching: frozenset[int] = frozenset()  # with one support: the bricks the drop-off touches
        self._near_of: BrickTask | None = None
        self._as_built: dict[int, tuple[float, float, float]] = {}
        #: the drop-off's deviation from the design relative to the wall: its neighbours' as built (follow_m)
        self.follow_m = np.zeros(3)
        self._follow_raw_m = np.zeros(3)  # the same, pulled back but not capped
        #: When (s) a brick of the wall was last in view (placement by the wall's markers; -inf: not yet)
        self.seen_s = -math.inf
        #: The bricks of the wall in that last view: id -> estimated top-face centre (world)
        self.estimates: dict[int, np.ndarray] = {}
        #: Every brick of the wall seen on the wall (within ``_REFERENCE_M`` of its design) in this placement
        self.seen_ids: set[int] = set()
        #: The drop-off as that last view alone puts it (world, the view's own telemetry): the bricks in view at
        #: their as-built places, the brick at its designed offsets to them (``place_taken``'s reference)
        self.view_target_m: np.ndarray | None = None

    def reset(self, design_top_m: np.ndarray) -> None:
        """A new placement whose designed effector target (the brick's top-face centre) is ``design_top_m``."""
        self.design_m = np.asarray(design_top_m, dtype=float).copy()
        self.tracker.reset(self.design_m)
        self.trend.reset(self.tracker.size)
        self.carried.reset()
        self.seen_s = -math.inf
        self.estimates = {}
        self.seen_ids = set()
        self.view_target_m = None

    @property
    def offset_m(self) -> np.ndarray:
        """The target's offset from the design so far."""
        assert self.tracker.center_m is not None
        return np.asarray(self.tracker.center_m - self.design_m, dtype=float)

    def track(self, uav: BrickUav, tel: Telemetry) -> bool:
        """One frame: move ``uav``'s motion and placement target with the wall's offset; True if moved (never
        without ``align_on_wall``)."""
        if not uav.on_wall or not uav.config.wall:
            return False
        if self._wall is None:
            self._wall = dict(uav.config.wall)
        task = uav.brick_task
        wall, own = self._wall, task.brick
        if self._near_of is not task:
            below = supports_of(wall, own, task.size_m)
            # one support (a tower's, a course's end): keep to it; on two, the mean of the wall seen, as before
            # (measured: keeping to one of two put a px4 pyramid's brick 47.7 mm off its neighbours, 11.6 before)
            self._near, self._near_of = (below if len(below) == 1 else frozenset()), task
            # ... and once one brick it touches has been seen, to the bricks it touches (off_support)
            self._touching = neighbours_of(wall, own, task.size_m) if self._near else frozenset()
            cfg = uav.config
            self._as_built = dict(task.wall_as_built) if cfg.wall_as_built else {}
            self.follow_m = follow_m(
                neighbours_of(wall, own, task.size_m),
                self._as_built,
                cfg.wall_pullback_m,
                cfg.wall_follow_cap_m,
            )
            self._follow_raw_m = follow_m(
                neighbours_of(wall, own, task.size_m), self._as_built, cfg.wall_pullback_m, math.inf
            )
        tags = frame_tags(uav.camera.read(), uav.camera, uav.config.markers)
        if uav.config.carried_look:
            self.carried.add(uav, tags, tel)
        seen = {t.marker_id // 2 for t in tags} - {own}
        estimates = {}
        for bid in seen & wall.keys():
            est = world_estimate(tags, bid, tel, uav._T_body_cam, uav._est_config)
            if est is not None:
                estimates[bid] = est[0]
        offset = wall_offset_m(estimates, wall, own, self._near, self._as_built)
        if offset is None and len(wall) <= 1:
            return self._lone(uav)
        if offset is None or off_support(self._touching, self.seen_ids, estimates.keys()):
            return False
        self.seen_s, self.estimates = uav._now_s, estimates
        self.seen_ids.update(
            bid
            for bid, top in estimates.items()
            if float(np.linalg.norm(np.asarray(top, dtype=float) - np.asarray(wall[bid], dtype=float)))
            <= _REFERENCE_M
        )
        follow = self.follow_m
        at_design = wall_offset_m(estimates, wall, own, self._near) if self._as_built else None
        if (
            at_design is not None
        ):  # the cap relative to the bricks in view, not to the design (follow_in_view)
            follow = follow_in_view(self._follow_raw_m, at_design - offset, uav.config.wall_follow_cap_m)
        carried = self.carried.world_m(uav._place_yaw_rad())
        self.view_target_m = self._base_m(wall.get(own)) + follow + offset - carried
        span_s = frames_span_s(uav.config.release_fresh_s)
        self.tracker.span_s = self.trend.mean_span_s = span_s
        delta = self.tracker.add(self.view_target_m, uav._now_s)
        self.trend.span_s = uav.config.wall_trend_s
        self.trend.drift_mps_per_sqrt_s = drift_noise_mps_per_sqrt_s(
            uav.config.wall_drift_mps_per_sqrt_s, uav.attempt.in_wind, uav._side.offset_m is not None
        )
        self.trend.drift_tau_s = uav.config.wall_drift_tau_s
        self.trend.add(
            uav._now_s,
            offset,
            frozenset(estimates.keys() & self._near) or frozenset(estimates),
        )
        if delta is None:
            return False
        uav.nav.shift(tuple(float(v) for v in delta))
        uav.attempt.place_effector_target_m = uav.attempt.place_effector_target_m + delta
        return True

    def _lone(self, uav: BrickUav) -> bool:
        """A lone brick (no other in the blueprint: issue 29's one-brick scenario) has no wall to align on: its
        drop-off is the design's, less the carried brick's offset on the magnet as the frames so far measure it
        (:mod:`masonry.fsm.carried_look`), so that the brick, not the effector, lands on it. Without it the
        offset (up to 6 mm) added to where the gate let go: on the real PX4 a brick let go 7 mm off rested 10 mm
        off, the offset the same way (docs/performance/autopilots.md, branch ``px447``). True if the target moved."""
        center = self.tracker.center_m
        if self.carried.frames == 0 or center is None:
            return False
        # the offset's running mean, not a wall's noisy sighting: followed to LONE_SHIFT_M, not the tracker's 2 mm
        delta = self.design_m - self.carried.world_m(uav._place_yaw_rad()) - center
        if float(np.linalg.norm(delta)) <= LONE_SHIFT_M:
            return False
        self.tracker.center_m = center + delta
        uav.nav.shift(tuple(float(v) for v in delta))
        uav.attempt.place_effector_target_m = uav.attempt.place_effector_target_m + delta
        return True

    def carry(self, uav: BrickUav) -> None:
        """One tick of the descent: move ``uav``'s motion and placement target along the wall's offset's trend since
        the frames the target is the mean of (:mod:`masonry.fsm.wall_trend`; with ``align_on_wall`` only)."""
        if not uav.on_wall:
            return
        delta = self.trend.step(uav._now_s)
        if delta is None:
            return
        uav.nav.shift(tuple(float(v) for v in delta))
        uav.attempt.place_effector_target_m = uav.attempt.place_effector_target_m + delta

    def _base_m(self, own_design_m: tuple[float, ...] | None) -> np.ndarray:
        """What the wall's offset is added to: the brick's own design. A target planned on the as-built poses
        (``Assign.planned``, :mod:`masonry.planner.as_built_plan`) already holds its supports' deviation, which
        the offset measures again, live and without the GNSS wander of the as-built looks: added to it, each
        course would add its supports' deviation twice (docs/performance/as-built.md, the px4 rows)."""
        if own_design_m is None:
            return self.design_m
        own = np.asarray(own_design_m, dtype=float)
        return own if float(np.linalg.norm(own - self.design_m)) > 1e-9 else self.design_m

    def taken(self, uav: BrickUav) -> str | None:
        """The reason not to release ``uav``'s brick at its drop-off: in the last view, fresh, a brick of the wall
        lies in the footprint of the drop-off as that view puts it (:mod:`masonry.fsm.place_taken`, "judged on the
        wall as it stands"); None otherwise (and always without ``align_on_wall``)."""
        hit = self._hit(uav, self.view_target_m)
        if hit is None:
            return None
        return (
            f"{PLACE_TAKEN} B{hit[0]} seen {hit[1] * 100:.1f} cm into the place of {uav.brick_task.id}; not released "
            f"there (it would rest on B{hit[0]}, off its course)"
        )

    def lags(self, uav: BrickUav) -> bool:
        """The drop-off flown (its target, smoothed over the last frames and carried on the wander's trend) would
        put the brick into a brick of the wall the last, fresh view shows, where that view's own drop-off is clear:
        True to hold the release (the target catches up, or the descent looks again; never a taken place)."""
        return self._hit(uav, np.asarray(uav.attempt.place_effector_target_m, dtype=float)) is not None

    def _hit(self, uav: BrickUav, target_m: np.ndarray | None) -> tuple[int, float] | None:
        """The brick of the last view deepest in the footprint at ``target_m`` (:func:`taken_by`), judged on a view
        no older than ``release_fresh_s`` only: an older one was placed in the world by the wander of its own
        time (the px4 pyramid, seed 1: a view 12 s old, the wander 14 cm on since, put B1 6.6 cm into B2's place
        where B2, released, would have lain clear of it)."""
        if not self.estimates or self._wall is None or target_m is None:
            return None
        if uav._now_s - self.seen_s > uav.config.release_fresh_s:
            return None
        task = uav.brick_task
        return taken_by(target_m, uav._place_yaw_rad(), task.size_m, self.estimates, self._wall, task.brick)

    def apply(self, uav: BrickUav) -> None:
        """A new leg toward the design (the descent): shift it by the offset found so far (with ``align_on_wall``)."""
        if not uav.on_wall:
            return
        offset = self.offset_m
        # the descent's target starts from the design again: no trend in it yet
        self.trend.shift_m = np.zeros(3)
        uav.nav.shift(tuple(float(v) for v in offset))
        uav.attempt.place_effector_target_m = uav.attempt.place_effector_target_m + offset
