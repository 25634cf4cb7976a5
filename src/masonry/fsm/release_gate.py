"""Release only on a fresh sighting of the wall (issue 30): a brick that stands on another is let go only if the
camera saw a brick of the wall at most ``UavConfig.release_fresh_s`` before.

Under GNSS (the ``px4`` model) the drop-off follows the bricks of the wall the camera sees
(:mod:`masonry.fsm.wall_align`); out of view, the last offset stands while the wander moves on: 6.4 mm rms per
axis in 0.5 s, 30 mm in 3 s (``benchmarks/bench_as_built.py --wander``). A tower's brick that lost its support
from view 0.9-7.5 s before the release landed 19.5-143 mm off it; the side look's last leg leaves the offset
0.3-0.4 s old when all goes well. So the release waits for a fresh sighting: with the offset older than
``release_fresh_s`` at the drop-off, the UAV flies back up to where a support is in view (the side look's
pre-release point, or right above the drop-off, ``RELOOK_CLIMB_M`` higher), hovers until the camera has seen the
wall for ``RELOOK_FRAMES`` frames and the UAV rests there, and flies the last leg again; a leg that does not reach
the drop-off within ``release_timeout_s`` of its end looks again too (not a failed descent while looks are left).
The side look's displaced descent is checked so too where it ends, before its last leg
(:meth:`ReleaseGate.before_leg`): flown on a stale offset, the leg can take the brick sideways under its supports'
tops. Bricks that stand on others are held so (their supports are built before them: there is something to
see), and a first-course brick once a brick beside it in its course has been seen on the wall in this placement
(issue 30, branch ``fresh31``: the px4 pyramid in 4 m/s let B0 go 2.4 s after its neighbour was last seen, 53.2 mm
off it), seen before the descent or in it (:meth:`ReleaseGate.track`); a tower's first brick, alone in its course,
is placed as before. A first-course drop-off whose looks all miss the wall (the neighbour under the carried brick's
shadow) flies its last leg and is let go as an unguarded one was, not a failed descent (tests/test_wall_as_built.py's
pyramid, seed 4: failing it failed the mission). A look that does not find the wall within
``RELOOK_WAIT_S`` looks again ``RELOOK_CLIMB_M`` higher (a wider view); after ``MAX_RELOOKS`` looks in one descent
without the wall the descent counts as failed, as one that did not reach its drop-off: the UAV aligns and
descends again, and after ``max_place_attempts`` the task fails with the reason said.

The rest before the leg is what makes the release fresh on a slower loop. On the ``px4`` SITL over MAVLink
(``masonry sitl --vehicle px4`` at x4: telemetry every 0.13 s of its time, a tick every 0.12 s) a leg started
after the five frames, the UAV still swinging, ended 4-7 cm past the drop-off and came back within 1.5 cm
1.5-3.8 s after the support left the view: every look missed the same way, and three failed descents failed the
task (tests/test_px4.py's B1, 6 of 8 runs). From rest the leg arrives 0.25-0.4 s after it, as in-process. A leg
still late after ``MAX_RELOOKS`` looks that each found the wall shows the vehicle cannot do better: the brick is
let go on the offset the last look measured (its age kept in ``ReleaseGate.stale_age_s``; the as-built look
measures where the brick ended up). Failing the descent instead, but in the last one allowed, was measured worse
(docs/performance/as-built.md; with three looks, on the px4 SITL model of 2026-12-04).

The side look's descent is the exception since branch ``px4rel36`` (issues 29/30): after its ``MAX_LEG_LOOKS``
looks, a last pass whose sighting is older than ``LAST_PASS_STALE_S`` (1 s) fails the descent, which is flown
again from the alignment with new looks (not in the last descent allowed: there the brick is let go as before).
Its pass had missed the drop-off; flown on blind, the UAV wandered about it and let go whenever the wander
brought it inside r_pl, on a target held at the offset of seconds before (the px4 towers in calm air, seed 7 B5:
4.2 s after the sighting, 10 mm from its target, the target 83 mm off the truth: 84.8 mm from its neighbour; on
the real PX4 13.8-20.7 mm as built, docs/performance/autopilots.md).

On the side look's last leg a pass that misses is looked again at once (:meth:`ReleaseGate.lost`, issue 30,
branch ``px4tow``): the support leaves the camera's view 7-15 cm before the drop-off (the carried brick's shadow
from the camera 10 cm beside the rod: 1.25 times the brick at the support's top, over both its markers), and the
``px4`` airframe wanders 2.5-3 cm per axis about its reference, so a pass lands inside r_pl within
``release_fresh_s`` of the last sighting about one time in three (towers seeds 0-9: 56 of 184 passes). Flown on,
the effector wandered into r_pl blind 1-4 s later, only for :meth:`ReleaseGate.allows` to look back up then; five
such looks left 4 of the 60 tower bricks let go stale (0.9-2.3 s, up to 34 mm off their support). The look now
starts as the sighting goes stale, and the side look's descent has ``MAX_LEG_LOOKS`` of them (20: in 4 m/s ten
left the px4 towers' worst bricks to a stale release, branch ``towers32``).

Inside r_pl, on the side look's last leg, the release waits for the nearest tick
(``UavConfig.release_closest_s``, the ``px4`` preset's 0.1 s: issue 30, branch ``px4tail``). That leg arrives at
0.2-0.3 m/s, 2-3 cm a tick, and the first tick inside the 1.5 cm disc let go anywhere in it: of the 6 px4
bricks over 2 cm off their neighbours over seeds 10-19 (towers, pyramid), the release (the true effector off the true target) was 12-20 mm in every one. So while
the effector's velocity brings it more than 1 mm nearer by the next tick, and the wall's sighting will still be
fresh then, it waits that tick; past the freshness it lets go as before (a hold into a look back up was measured
worse: the drop-off ages, docs/performance/as-built.md, "The px4 tail over 20 seeds"). On every descent, not
only that leg, it was a draw (the pyramid better, the rotated bond worse, seeds 0-9 21.3 mm against 19.3).

In calm air, on that leg, a tick inside r_pl but more than ``UavConfig.release_leg_m`` (0 by default, the ``px4``
preset's 1 cm since branch ``towers38``, see below) from the drop-off is passed over while looks back up are left (:meth:`ReleaseGate.wide`, issue 30, branch
``release35``): the support leaves the view 7-11 cm out, the UAV trails the leg's reference by 4-8 cm and catches
up through the disc at 0.2-0.4 m/s as the sighting goes stale, and the first tick inside was let go anywhere in it
(the px4 towers, calm, seeds 0-19: 8 of 120 bricks over 2 cm of their neighbours; with it none, 4-6 s more
descending a brick). A pass that comes no nearer is flown again from the look point (:meth:`lost`); the last
look's pass is let go within r_pl as before. Not in a wind: passes within 1 cm are rarer there, and on the towers'
seeds 10-19 12 bricks were let go stale after the looks (8 of 60 over 2 cm against 1). Off in the ``px4`` preset on the merged main:
with the learnt last-leg lag (:meth:`masonry.fsm.side_look.SideLook.leg_lag_s`) beside it, the towers in calm air
went 3 of 60 over 2 cm, one 84.8 mm off (docs/performance/as-built.md). Since branch ``px4rel36`` the learnt lag takes
no step on a pass this rule passed over in time, and the stale release after the looks flies the descent again
(above): the px4 model's towers in calm air then 3 of 120 over 2 cm, 25.9 mm at most (the preset as it stands 11 of
120), but on the real PX4 the case study took 420-649 s (bound 720) against 199-264 s: its passes come within 1 cm
seldom, and 6 descents in two runs ran out of their twenty looks. So it stayed off in the preset until branch
``towers38`` (issue 30): with the release timed inside the tick (below) the rule judges the pass's predicted nearest
point, not the tick, and it holds for the first ``UavConfig.release_leg_looks`` looks only (the ``px4`` preset's 10;
later passes are let go within r_pl): the px4 model's towers in calm air, seeds 0-29, 7 -> 1 of 180 bricks over 2 cm
of their neighbours, 20.8 -> 23.4 s descending a brick. Taken out of the preset after one failure of the real PX4's
one-brick scenario (whose lone drop-off is never guarded, so never judged by it) and back since branch ``px439``:
on the real PX4 the case study's calm placements were let go up to 14.4 mm off without it, and the target's
sighting, the release's timing and the scatter add 5-10 mm (docs/performance/autopilots.md).

With the wall in view at the release tick (seen this tick or the last), on any descent, a tick inside r_pl but
more than ``UavConfig.release_hold_m`` off (the ``px4`` preset's 1 cm) is passed over too, up to
``release_hold_s`` (3.5 s) past the leg's end (issues 29/30, branch ``px4land``). On the px4 model refitted to the
real PX4 the airframe wanders 4-5 cm/s about its setpoint and the effector crosses the 1.5 cm disc rather than
settling in it: the first tick inside let go at its edge (the surveyed pyramid of tests/test_wall_anchor.py, seed
3: B7 released 14.5 mm off its target, and B8, B9 kept their designed offsets to it, 3.1-3.3 cm from their
design). With the wall in view the offset stays fresh while the UAV waits for a nearer pass; out of view (the side
look's last leg) waiting ages it, so there only the nearest-tick rule above holds (a 1 cm gate without that
condition, branch ``relpose``, moved the maxima both ways: docs/performance/as-built.md).

In calm air the release on that leg is timed inside the tick (``UavConfig.release_ahead_s``, 0 by default, the
``px4`` preset's 0.1 s; :meth:`ReleaseGate.ahead`, issue 30, branches ``windrel36`` and ``calm37``): the leg crosses
the 1.5 cm disc at 0.2-0.4 m/s, 2-4 cm a tick, and the sighting is 0.3-0.4 s old there, too old to wait a tick, so a
tick's release let go 10.6 mm rms from the true drop-off (px4 towers in calm air, seeds 0-19; the pass's closest
point between ticks 7.7). At a tick the gate predicts, from the error and the effector's velocity, the pass's
nearest point to the drop-off; if it lies inside the coming tick (before its end), the drop-off tests judge the
error predicted there and the brick is let go then (``Gripper.release_at``: the simulator inside its physics
step). From a tick outside r_pl only with a gripper that times it (``Gripper.can_time_release``; one that cannot
would let go out there). A nearest point at the tick's end or beyond is left to the next tick (timed at the tick's
end too, passes that would have missed were let go on a prediction rather than flown again: the px4 towers in 4
m/s went 6 of 60 bricks over 2 cm against 1). The px4 towers in calm air, seeds 0-29: 16 -> 7 of 180 bricks over 2
cm of their neighbours (from ticks inside r_pl only, seeds 0-19: 11 -> 8 of 120), with no time added. Not in a
wind: there, from any tick, the rotated bond in 4 m/s went 4/150 -> 7/150 over 2 cm, and from ticks inside r_pl
its maximum 23.9 -> 28.0 mm (docs/performance/as-built.md).

In a wind ``UavConfig.release_leg_wind_m`` stands for ``release_leg_m`` (0 by default and in the presets: a switch,
branch ``bond41``): the px4 rotated bond's bricks over 2 cm in 4 m/s were let go at ticks the gate measured 13-14 mm
off; with 1.2 cm the bond 4 -> 2 and 4 -> 1 of 150 (seeds 0-9, 10-19), the towers 0 -> 2 and 5 -> 2 of 60.

On a guarded descent with the wall seen within ``release_fresh_s``, a tick more than ``LOW_M`` under the drop-off's
height is passed over (:meth:`ReleaseGate.low`, branch ``fresh31``): the release's height test is one-sided (a brick
pressed down rests on its support, :mod:`masonry.fsm.dropoff_reach`), but an effector that low has brought its
brick in beside its supports, under their tops (the side look's last leg sinking in a gust).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from masonry.fsm.side_look import FINAL_LEG_S, PRE_RELEASE_GAP_M
from masonry.fsm.wall_align import neighbours_of, supports_of

if TYPE_CHECKING:
    from masonry.fsm.brick import BrickUav
    from masonry.ports import Telemetry

__all__ = [
    "CLOSING_MIN_M",
    "LAST_PASS_STALE_S",
    "LOW_M",
    "MAX_LEG_LOOKS",
    "MAX_RELOOKS",
    "RELOOK_CLIMB_M",
    "RELOOK_FRAMES",
    "RELOOK_WAIT_S",
    "ReleaseGate",
    "nearest_pass_s",
    "reach_s",
]

#: Looks back up per descent before it counts as failed (or, each having found the wall, before a late leg is let
#: go on the last look's offset). 3 until 2026-12-04: the px4 towers' worst brick over seeds 0-9 was a release on a
#: 1.8 s old sighting after 3 looks (51.7 mm; with 5: 30.4 mm, fresh; docs/performance/as-built.md).
MAX_RELOOKS = 5
#: The same on the side look's descent, whose looks each follow a pass of the last leg that missed the drop-off
#: (:meth:`ReleaseGate.lost`): a pass lands in r_pl while the sighting is fresh about one time in three on the px4
#: model, so five looks left 4 of 60 tower bricks to a stale release (docs/performance/as-built.md, branch
#: ``px4tow``); begun as the sighting goes stale, ten of them took less time than five had (25.8 -> 22.5 s a brick).
#: 20 since branch ``towers32``: in 4 m/s a pass lands fresh less often, and the px4 towers let 6 of 60 bricks go
#: after ten looks on sightings 1.6-3.7 s old, the four worst of them 29-79 mm off their neighbours
#: (docs/performance/as-built.md).
MAX_LEG_LOOKS = 20
#: With the side look's looks all flown, its last pass is let go on a sighting at most this old (s); older, the
#: descent fails and is flown again while descents are left (:meth:`ReleaseGate.lost`).
LAST_PASS_STALE_S = 1.0
#: A look that did not find the wall is followed by one this much higher (m) (the first: ``PRE_RELEASE_GAP_M`` +
#: this).
RELOOK_CLIMB_M = 0.05
#: Sightings of the wall at the look point before the last leg is flown again (the wall alignment's mean is over
#: its last five: all of them new).
RELOOK_FRAMES = 5
#: Hover at a look point at most this long (s) for the wall to come into view, then look from higher up.
RELOOK_WAIT_S = 3.0
#: A release inside r_pl waits a tick (``ReleaseGate.closing``) only if the next is this much nearer (m).
CLOSING_MIN_M = 0.001
#: On a fresh sighting of the wall, an effector more than this far (m) below its drop-off is not let go there
#: (``ReleaseGate.low``): the brick is not on its supports but beside them, under their tops.
LOW_M = 0.03


def nearest_pass_s(error_m: np.ndarray, velocity_mps: np.ndarray, most_s: float) -> float:
    """When (s, in [0, ``most_s``]) ``error_m + velocity_mps * t`` (m, any dimension) is shortest: the straight
    pass's nearest point to the origin, clamped to the interval (0 for a still or receding effector)."""
    speed2 = float(np.dot(velocity_mps, velocity_mps))
    if most_s <= 0.0 or speed2 <= 0.0:
        return 0.0
    return min(most_s, max(0.0, -float(np.dot(error_m, velocity_mps)) / speed2))


def reach_s(release_ahead_s: float, tick_interval_s: float) -> float:
    """How far ahead (s) a timed release may be predicted: ``release_ahead_s``, but no farther than the ticks come
    (the last interval between them, where shorter by over a millisecond): the next tick predicts the pass again on
    fresher telemetry. On the real PX4 the last leg ticks at 20 Hz and its telemetry's velocity trails the reported
    position's on the accelerating pass (15 % over 0.1 s, at times twice that): a release predicted 0.096 s ahead let
    go 29 mm from where it was predicted (issues 29/30, branch px439). A simulated mission ticks at 0.1 s: unchanged."""
    if tick_interval_s < release_ahead_s - 1e-3:
        return max(0.0, tick_interval_s)
    return release_ahead_s


class ReleaseGate:
    """One descent's release rule and its looks back up (see the module docstring)."""

    def __init__(self) -> None:
        self.guarded = (
            False  # the drop-off stands on bricks of the wall: the release waits for a fresh sighting
        )
        self._beside: frozenset[int] = frozenset()  # a first-course drop-off's neighbours in its course
        self.relooks = 0  # looks back up flown in this descent
        self.looking = False  # flying to, or hovering at, a look point
        self._frames = 0  # sightings of the wall since the look point was reached
        self._seen_s = -math.inf  # the last of them counted
        self._height_m = RELOOK_CLIMB_M  # the look point's height over the pre-release point
        #: At a release after ``MAX_RELOOKS`` looks that each found the wall: how old (s) its last sighting was
        self.stale_age_s: float | None = None
        #: This tick's timed release (s after the tick; 0: at the tick): :meth:`ahead`
        self.ahead_s = 0.0

    def reset(self, uav: BrickUav) -> None:
        """A new descent onto ``uav``'s drop-off (guarded only with ``align_on_wall`` and ``release_fresh_s``)."""
        cfg, task = uav.config, uav.brick_task
        self.relooks, self.looking, self.stale_age_s, self.ahead_s = 0, False, None, 0.0
        self._height_m = RELOOK_CLIMB_M
        wall = dict(cfg.wall)
        below = supports_of(wall, task.brick, task.size_m)
        on = bool(uav.on_wall and cfg.release_fresh_s > 0.0 and wall)
        # a first-course brick: guarded once a brick beside it in its course has been seen on the wall in this
        # placement (there is something to see again from the look point; a tower's first brick, alone in its
        # course, is not), before the descent or during it (:meth:`track`)
        self._beside = (
            neighbours_of(wall, task.brick, task.size_m) - below if on and not below else frozenset()
        )
        self.guarded = bool(on and below)
        self.track(uav)

    def track(self, uav: BrickUav) -> None:
        """One tick of the descent: a first-course drop-off becomes guarded once a brick beside it is seen."""
        if not self.guarded and self._beside & uav._wall.seen_ids:
            self.guarded = True

    def fresh(self, uav: BrickUav) -> bool:
        """The wall was seen recently enough to release now (always, unguarded)."""
        return not self.guarded or uav._now_s - uav._wall.seen_s <= uav.config.release_fresh_s

    def ahead(self, uav: BrickUav, tel: Telemetry) -> float:
        """This tick's timed release on the side look's last leg in calm air (s after the tick, kept in
        ``ahead_s``): when the effector, its error carried on its velocity, passes nearest the drop-off within the
        coming ``UavConfig.release_ahead_s``; 0 off that leg, in a wind, unguarded, or with the setting 0 (see the
        module docstring). From a tick outside r_pl only with a gripper that times its release.
        The drop-off tests (:func:`masonry.fsm.dropoff_reach.dropoff_error_m`, :meth:`closing`) then judge the
        error predicted at that instant, and the release lets go then (``Gripper.release_at``)."""
        cfg = uav.config
        self.ahead_s = 0.0
        # calm air only: in 4 m/s the rotated bond went 4/150 -> 7/150 bricks over 2 cm with it (from any tick;
        # 2/150 from ticks inside r_pl, the maximum 23.9 -> 28.0 mm: docs/performance/as-built.md, branch windrel36)
        if (
            cfg.release_ahead_s <= 0.0
            or not self.guarded
            or not uav._side.final
            or self.looking
            or uav.attempt.in_wind
        ):
            return 0.0
        error_m = (
            np.asarray(uav.effector.position(tel), dtype=float)[:2]
            - np.asarray(uav.attempt.place_effector_target_m, dtype=float)[:2]
        )
        # from a tick outside r_pl too (its pass's nearest point inside the coming tick: the px4 towers in calm air,
        # seeds 0-19, 8 -> 4 of 120 bricks over 2 cm against ticks inside r_pl only; branch calm37), but only with a
        # gripper that times it: one that lets go at once would let go out there
        if float(np.hypot(*error_m)) > cfg.placement_radius_m and not uav.gripper.can_time_release():
            return 0.0
        velocity_mps = np.asarray(tel.velocity_mps, dtype=float)[:2]
        most_s = reach_s(cfg.release_ahead_s, uav.tick_interval_s)
        ahead_s = nearest_pass_s(error_m, velocity_mps, most_s)
        # nearest at the interval's end or beyond it: the next tick measures it (the rules at the tick, as before)
        self.ahead_s = ahead_s if ahead_s < most_s else 0.0
        return self.ahead_s

    def closing(self, uav: BrickUav, tel: Telemetry) -> bool:
        """Within r_pl of the drop-off this tick, on the side look's last leg: True to let one more tick pass.

        While the effector's velocity brings it more than 1 mm nearer by the next tick and the wall's sighting is
        still fresh then (``UavConfig.release_closest_s``, the ``px4`` preset's tick; see the module docstring).
        Never past the sighting's freshness: a release held into a look back up ages the drop-off more than it
        gains. A drop-off with no brick of the wall seen in its placement, none under it and no other brick in the
        blueprint (a lone brick, issue 29's scenario) has nothing to age: it waits for a tick within ``release_hold_m`` as with the wall in view."""
        cfg = uav.config
        dt_s = cfg.release_closest_s
        # no brick of the wall seen in this placement, none under it, none other in the blueprint: the drop-off is
        # the design's, nothing ages. A wall's first course is not alone: there the hold took 3.5 s of the 4 s
        # release window and the few ticks within it failed the windowed height test (a brick resting on its
        # neighbour's top bounces upward only), the px4 rotated bond's first course failed three descents in a row
        alone = not self.guarded and uav._wall.seen_s == -math.inf and len(cfg.wall) <= 1
        if dt_s <= 0.0 or (not alone and uav._now_s + dt_s - uav._wall.seen_s > cfg.release_fresh_s):
            return False
        error_m = (
            np.asarray(uav.effector.position(tel), dtype=float)[:2]
            - np.asarray(uav.attempt.place_effector_target_m, dtype=float)[:2]
        )
        velocity_mps = np.asarray(tel.velocity_mps, dtype=float)[:2]
        # a timed release (:meth:`ahead`) judged at its instant: before the coming tick's end, nothing to wait for
        error = float(np.hypot(*(error_m + velocity_mps * self.ahead_s)))
        # with the wall in view the 1 cm hold judges a timed release's predicted error too: timed at once, the px4
        # rotated bond in calm air went 7.6 -> 8.4 mm mean off its neighbours (seeds 0-19, branch calm37)
        if (
            error > cfg.release_hold_m > 0.0
            and uav._now_s - uav.nav.end_s <= cfg.release_hold_s
            and (alone or uav._now_s - uav._wall.seen_s <= dt_s)
        ):
            return True
        if self.ahead_s > 0.0:
            return False
        if alone or not uav._side.final:
            return False
        ahead_m = error_m + velocity_mps * dt_s
        return float(np.hypot(*ahead_m)) < float(np.hypot(*error_m)) - CLOSING_MIN_M

    def wide(self, uav: BrickUav, tel: Telemetry) -> bool:
        """Within r_pl of the drop-off this tick, on the side look's last leg in calm air: True to let it pass, the
        effector farther than ``UavConfig.release_leg_m`` from the drop-off and looks back up left (guarded only;
        see the module docstring). The pass goes on; if no tick of it comes within ``release_leg_m`` while the
        sighting is fresh, :meth:`lost` flies it again from the look point. The last look's pass is let go within
        r_pl."""
        cfg = uav.config
        leg_m = cfg.release_leg_wind_m if uav.attempt.in_wind else cfg.release_leg_m
        if leg_m <= 0.0 or not self.guarded or not uav._side.final:
            return False
        if self.relooks >= self._most(uav) or 0 < cfg.release_leg_looks <= self.relooks:
            return False
        error_m = (
            np.asarray(uav.effector.position(tel), dtype=float)[:2]
            - np.asarray(uav.attempt.place_effector_target_m, dtype=float)[:2]
        )
        # a timed release (:meth:`ahead`) judged at its instant: the pass's predicted nearest point (branch towers38)
        if self.ahead_s > 0.0:
            error_m = error_m + np.asarray(tel.velocity_mps, dtype=float)[:2] * self.ahead_s
        wide = float(np.hypot(*error_m)) > leg_m
        if wide and self.fresh(uav):
            uav._side.on_time = True  # (the learnt lag does not step on this pass: it was in r_pl in time)
        return wide

    def low(self, uav: BrickUav, tel: Telemetry) -> bool:
        """Within r_pl of the drop-off this tick: True to let it pass, the effector more than ``LOW_M`` below the
        drop-off's height as the wall's fresh sighting measures it (guarded only; see the module docstring).

        The release's height test is one-sided (a brick pressed down rests on its support, masonry.fsm.dropoff_reach),
        and a brick set down from above is held up by its supports: measured on the wall, its effector stays within
        2 cm of the drop-off's height. One lower has come in from the side under its supports' tops (the side
        look's last leg in a gust's sink: px4 rotated bond in 4 m/s, seed 5, B11 let go 6.8 cm low rested a course
        lower, 9.4 cm below its course height)."""
        if not self.guarded or not self.fresh(uav):
            return False
        below_m = float(
            np.asarray(uav.attempt.place_effector_target_m, dtype=float)[2]
            - np.asarray(uav.effector.position(tel), dtype=float)[2]
        )
        return below_m > LOW_M

    def allows(self, uav: BrickUav, tel: Telemetry) -> bool:
        """At the drop-off: True to release; else a look back up has begun.

        The last leg is flown only after a look that found the wall: arriving stale after ``MAX_RELOOKS`` of them,
        the vehicle cannot arrive sooner, and the release goes on the offset the last look measured."""
        if self.fresh(uav):
            return True
        if self.relooks >= self._most(uav):
            if self._descends_again(uav):
                return False
            self.stale_age_s = uav._now_s - uav._wall.seen_s
            return True
        self._look(uav, tel)
        return False

    def before_leg(self, uav: BrickUav, tel: Telemetry) -> bool:
        """The side look's displaced descent over, its last leg due: True if a look back up has begun instead (the
        wall not seen within ``release_fresh_s``, looks left). The leg flies the carried brick sideways at the height
        the offset last measured put it: out of view, the vertical wander moves on, and a brick flown in low passes
        under its supports' tops into the course below (px4 rotated bond, seed 12: B8's support out of view for the
        7 s of its descent, the wander 11 cm down, B8 a course low). From the look the leg starts fresh."""
        if self.fresh(uav) or self.relooks >= self._most(uav):
            return False
        uav._side.final = True  # the look flies the leg when it has found the wall
        self._look(uav, tel)
        return True

    def lost(self, uav: BrickUav, tel: Telemetry) -> bool:
        """On the side look's last leg, the wall's sighting gone stale before a release: True if a look back up has
        begun at once (guarded, looks left).

        The leg's pass missed the drop-off: the support left the view 7-15 cm before it (the carried brick's shadow
        from the camera) and the airframe's wander (2.5-3 cm per axis about the reference on the ``px4`` model)
        put the pass outside r_pl. Flying on blind, the effector wandered into r_pl 1-4 s later, where
        :meth:`allows` refused it and looked back up only then (docs/performance/as-built.md, branch ``px4tow``)."""
        if not self.guarded or self.looking or not uav._side.final or self.fresh(uav):
            return False
        if self.relooks >= self._most(uav):
            return self._descends_again(uav)
        self._look(uav, tel)
        return True

    @staticmethod
    def _descends_again(uav: BrickUav) -> bool:
        """The side look's looks all flown and the last pass's sighting older than ``LAST_PASS_STALE_S``: True if
        the descent has failed (the UAV aligns above the drop-off again and descends with new looks), not on the
        last descent allowed (there the brick is let go on the last look's offset, as before)."""
        if uav._side.offset_m is None or uav._now_s - uav._wall.seen_s <= LAST_PASS_STALE_S:
            return False
        if uav.attempt.place_attempts + 1 >= uav.config.max_place_attempts:
            return False
        uav.attempt.place_attempts += 1
        uav.timeout()
        return True

    def retries(self, uav: BrickUav, tel: Telemetry) -> bool:
        """The drop-off not reached within ``release_timeout_s`` of the leg's end: True if a look back up has
        begun instead of a failed descent (guarded, looks left: the look point has the wall in view again)."""
        if not self.guarded or self.relooks >= self._most(uav):
            return False
        self._look(uav, tel)
        return True

    @staticmethod
    def _most(uav: BrickUav) -> int:
        """Looks back up allowed in this descent: ``MAX_LEG_LOOKS`` on the side look's, else ``MAX_RELOOKS``."""
        return MAX_LEG_LOOKS if uav._side.offset_m is not None else MAX_RELOOKS

    def _look(self, uav: BrickUav, tel: Telemetry) -> None:
        """Fly to the next look point, or fail the descent after ``MAX_RELOOKS`` looks (``MAX_LEG_LOOKS`` on the
        side look's descent; the last without the wall). Failing the side look's descent at ``MAX_RELOOKS`` for a
        look that did not find the wall failed one px4 4 m/s bond mission of three (seeds 0-2; all three
        complete so: docs/performance/as-built.md, branch ``px4tow``)."""
        if self.relooks >= self._most(uav):
            self.looking = False
            # a first course's neighbour may hide under the carried brick's shadow: let go as unguarded
            if self._beside:
                self._leg(uav, tel)
            else:
                self._fail(uav)
            return
        self.relooks += 1
        if self.looking:  # the last look did not find the wall: a wider view, from higher up
            self._height_m += RELOOK_CLIMB_M
        self.looking, self._frames, self._seen_s = True, 0, uav._wall.seen_s
        side = uav._side.offset_m
        look = np.asarray(uav.attempt.place_effector_target_m, dtype=float) + (
            side if side is not None else np.zeros(3)
        )
        look = look + np.array([0.0, 0.0, PRE_RELEASE_GAP_M + self._height_m])
        yaw = uav._place_yaw_rad()
        uav._fly_to(tel, uav.effector.body_target(look, yaw), FINAL_LEG_S, yaw)

    @staticmethod
    def _leg(uav: BrickUav, tel: Telemetry) -> None:
        """Fly the last leg, from the look point to the drop-off."""
        yaw = uav._place_yaw_rad()
        uav._fly_to(
            tel,
            uav.effector.body_target(uav.attempt.place_effector_target_m, yaw),
            FINAL_LEG_S,
            yaw,
            lag_s=uav._side.leg_lag_s(uav),
        )

    def _fail(self, uav: BrickUav) -> None:
        """The looks of this descent did not find the wall: a failed descent (the task fails after the last)."""
        uav.attempt.place_attempts += 1
        if uav.attempt.place_attempts < uav.config.max_place_attempts:
            uav.timeout()
            return
        age_s = uav._now_s - uav._wall.seen_s
        seen = f"last seen {age_s:.1f} s before" if math.isfinite(age_s) else "never seen"
        uav.abort(
            reason=f"the wall under brick {uav.brick_task.brick} not seen within "
            f"{uav.config.release_fresh_s:.2f} s of its release after {self.relooks} looks in each of "
            f"{uav.attempt.place_attempts} descents ({seen})"
        )

    def step(self, uav: BrickUav, tel: Telemetry) -> bool:
        """One tick of a look back up: True while it lasts (no release); at its end, the last leg flown again."""
        if not self.looking:
            return False
        now = uav._now_s
        if now < uav.nav.end_s:
            return True
        seen_s = uav._wall.seen_s
        if seen_s > self._seen_s:
            self._seen_s = seen_s
            self._frames += 1
        found = self._frames >= RELOOK_FRAMES and now - seen_s <= uav.config.release_fresh_s
        waited = now > uav.nav.end_s + RELOOK_WAIT_S
        # the leg from a UAV at rest at the look point (a swinging start overshoots the drop-off), or from where it
        # swings once it has waited RELOOK_WAIT_S there with the wall found
        if found and (waited or uav.nav.rests_at(tel, uav.nav.target_m)):
            self.looking = False
            self._leg(uav, tel)
        elif waited:
            self._look(uav, tel)  # higher up, or the descent failed
        return True
