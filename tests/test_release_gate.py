"""A brick that stands on others is released only on a fresh sighting of the wall (issue 30): lost from view at
the drop-off, the brick UAV looks again from above first, a bounded number of times, then fails with the reason
said; a vehicle that finds the wall at every look but cannot arrive in time is released on the last look's offset
(masonry.fsm.release_gate)."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import TYPE_CHECKING, cast

import numpy as np
import pytest
import yaml

from fsm_rig import BRICK_ID, Rig, brick_task
from masonry.blueprint import parse_blueprint
from masonry.fakes import FakeBrick
from masonry.fsm import release_gate
from masonry.fsm.config import UavConfig
from masonry.fsm.release_gate import LAST_PASS_STALE_S, LOW_M, MAX_LEG_LOOKS, MAX_RELOOKS, ReleaseGate
from masonry.fsm.tuning import uav_settings
from masonry.fsm.wall_align import supports_of, wall_offset_m
from masonry.mission.simulate import simulate
from px4_sitl import ONE_BRICK

if TYPE_CHECKING:
    from masonry.fsm.brick import BrickUav
    from masonry.ports import Telemetry

DROP = (0.0, 0.5, 0.25)  # the brick's centre: a second-course brick
SUPPORT = 3
SUPPORT_TOP = (0.0, 0.5, 0.20)
WALL = ((SUPPORT, SUPPORT_TOP), (BRICK_ID, (DROP[0], DROP[1], DROP[2] + 0.05)))
ON_WALL = {"align_on_wall": True, "wall": WALL, "side_look": False}


class Watch:
    """Per tick: when the support's markers are in the camera's frame, and at the release how old the last
    sighting of the wall was and how many looks back up were flown."""

    def __init__(self, hide: str) -> None:
        # "once": hidden until the first look back up; "always": from the descent on; "legs": in view only while
        # looking back up (a vehicle whose last leg is slower than the rule allows)
        self.hide = hide
        self.release_age_s: float | None = None
        self.relooks_at_release: int | None = None
        self.max_relooks = 0

    def __call__(self, rig: Rig) -> None:
        uav = rig.uav
        gate = uav._gate
        self.max_relooks = max(self.max_relooks, gate.relooks)
        descending = uav.state == "place_descend"
        if self.hide == "always":
            hidden = descending or (uav.state == "place_align" and uav.attempt.place_attempts > 0)
        elif self.hide == "legs":
            hidden = descending and not gate.looking
        else:
            hidden = descending and gate.relooks == 0
        rig.camera.hidden = frozenset({2 * SUPPORT, 2 * SUPPORT + 1}) if hidden else frozenset()
        if uav.state == "place_release" and self.release_age_s is None:
            self.release_age_s = uav._now_s - uav._wall.seen_s
            self.relooks_at_release = gate.relooks


def _rig(**config: object) -> Rig:
    rig = Rig(tasks=[brick_task(position=DROP)], config={**ON_WALL, **config})
    rig.camera.bricks.append(FakeBrick(SUPPORT, SUPPORT_TOP, 0.0))
    return rig


def test_a_release_waits_for_a_fresh_sighting_of_the_support() -> None:
    watch = Watch("once")
    rig = _rig().run(on_tick=watch)
    assert rig.link.results[0].status == "done"
    # the support vanished for the whole descent: at the drop-off the UAV looked again before letting go
    assert watch.relooks_at_release == 1
    assert watch.release_age_s is not None and watch.release_age_s <= UavConfig.release_fresh_s
    assert rig.followed("place_descend", "place_release")


def test_without_the_rule_the_brick_is_let_go_on_the_stale_offset() -> None:
    """The same scene with ``release_fresh_s`` 0 (the rule off): released with the support out of view."""
    watch = Watch("once")
    rig = _rig(release_fresh_s=0.0).run(on_tick=watch)
    assert rig.link.results[0].status == "done"
    assert watch.relooks_at_release == 0
    assert watch.release_age_s is not None and watch.release_age_s > 1.0


def test_a_support_never_seen_again_fails_the_task_with_the_reason_said() -> None:
    watch = Watch("always")
    rig = _rig().run(on_tick=watch)
    result = rig.link.results[0]
    assert result.status == "failed"
    assert watch.release_age_s is None  # never let go on the drop-off
    assert watch.max_relooks == MAX_RELOOKS
    assert rig.uav.attempt.place_attempts == rig.config.max_place_attempts
    assert f"the wall under brick {BRICK_ID} not seen within 0.45 s of its release" in result.reason
    assert f"after {MAX_RELOOKS} looks in each of {rig.config.max_place_attempts} descents" in result.reason


def test_a_last_leg_slower_than_the_rule_is_released_after_the_looks_on_the_last_offset() -> None:
    """The support in view at every look point, out of view on every leg to the drop-off (1.2 s): the px4 SITL's
    case, whose last leg swings through the drop-off 1.5-3.8 s after the support left the view. No look can make
    the release fresh: after the looks the brick is let go on the offset the last one measured, in the first
    descent, and the age is kept."""
    watch = Watch("legs")
    rig = _rig().run(on_tick=watch)
    result = rig.link.results[0]
    assert result.status == "done"
    assert watch.relooks_at_release == MAX_RELOOKS
    assert rig.uav.attempt.place_attempts == 0  # no descent failed
    gate = rig.uav._gate
    assert watch.release_age_s is not None and watch.release_age_s > UavConfig.release_fresh_s
    assert gate.stale_age_s is not None and math.isclose(gate.stale_age_s, watch.release_age_s, abs_tol=0.11)


def test_a_first_course_brick_has_no_support_and_is_not_held() -> None:
    wall = dict(WALL)
    assert supports_of(wall, BRICK_ID, (0.30, 0.15, 0.10)) == {SUPPORT}
    assert supports_of(wall, SUPPORT, (0.30, 0.15, 0.10)) == frozenset()
    # a first-course brick (nothing under it in the wall), nothing of the wall in view: placed as before
    first = ((BRICK_ID, (2.0, 0.5, 0.10)), (SUPPORT, SUPPORT_TOP))
    watch = Watch("always")
    rig = Rig(tasks=[brick_task(position=(2.0, 0.5, 0.05))], config={**ON_WALL, "wall": first}).run(
        on_tick=watch
    )
    assert rig.link.results[0].status == "done"
    assert not rig.uav._gate.guarded and watch.max_relooks == 0


NEIGHBOUR = 4
#: A first-course brick (its top 0.10 m up) and the brick beside it in its course, touching it
FIRST_COURSE = ((BRICK_ID, (0.0, 0.5, 0.10)), (NEIGHBOUR, (0.30, 0.5, 0.10)))


class FirstWatch:
    """The first course's neighbour: hidden in the first descent until a look back up (``"once"``), or in every
    frame of the placement (``"never"``); at the release how old the last sighting was and the looks flown."""

    def __init__(self, hide: str) -> None:
        self.hide = hide
        self.release_age_s: float | None = None
        self.relooks_at_release: int | None = None
        self.guarded = False

    def __call__(self, rig: Rig) -> None:
        uav = rig.uav
        gate = uav._gate
        self.guarded = self.guarded or gate.guarded
        if self.hide == "never":
            hidden = True
        elif self.hide == "descent":  # seen while it aligns, never again in the descent nor from a look point
            hidden = uav.state == "place_descend"
        elif self.hide == "late":  # out of view while it aligns; seen in the descent's first second only
            descending = uav.state == "place_descend"
            hidden = not descending or (uav._now_s - uav._entered_s > 1.0 and gate.relooks == 0)
        else:
            hidden = uav.state == "place_descend" and gate.relooks == 0
        rig.camera.hidden = frozenset({2 * NEIGHBOUR, 2 * NEIGHBOUR + 1}) if hidden else frozenset()
        if uav.state == "place_release" and self.release_age_s is None:
            self.release_age_s = uav._now_s - uav._wall.seen_s
            self.relooks_at_release = gate.relooks


def _first_course_rig() -> Rig:
    rig = Rig(tasks=[brick_task(position=(0.0, 0.5, 0.05))], config={**ON_WALL, "wall": FIRST_COURSE})
    rig.camera.bricks.append(FakeBrick(NEIGHBOUR, FIRST_COURSE[1][1], 0.0))
    return rig


def test_a_first_course_brick_whose_neighbour_was_seen_is_released_only_on_a_fresh_sighting() -> None:
    """Nothing under it, but the brick beside it in its course seen while it aligned: lost from view in the
    descent, the UAV looks again before letting go (the px4 pyramid in 4 m/s, seed 4: B0 let go 2.4 s after its
    neighbour was last seen, 53.2 mm off it; issue 30, branch ``fresh31``)."""
    watch = FirstWatch("once")
    rig = _first_course_rig().run(on_tick=watch)
    assert rig.link.results[0].status == "done"
    assert watch.guarded
    assert watch.relooks_at_release == 1
    assert watch.release_age_s is not None and watch.release_age_s <= UavConfig.release_fresh_s


def test_a_first_course_brick_is_guarded_from_the_neighbours_first_sighting_in_the_descent() -> None:
    """The neighbour out of view while the UAV aligned, seen early in the descent, then lost: guarded from then
    on (the px4 3-course pyramid of tests/test_wall_align.py, seed 1: B2 was let go 5.6 s after B1 was last seen,
    11 cm off it, when only a sighting before the descent counted)."""
    watch = FirstWatch("late")
    rig = _first_course_rig().run(on_tick=watch)
    assert rig.link.results[0].status == "done"
    assert watch.guarded
    assert watch.relooks_at_release is not None and watch.relooks_at_release >= 1
    assert watch.release_age_s is not None and watch.release_age_s <= UavConfig.release_fresh_s


def test_a_first_course_brick_whose_looks_all_miss_its_neighbour_is_let_go_not_failed() -> None:
    """The neighbour seen while aligning, then under the carried brick's shadow from every look point: after the
    looks the brick is let go as an unguarded one was, no descent failed (failing it failed
    tests/test_wall_as_built.py's px4 pyramid, seed 4); a drop-off on supports still fails (see above)."""
    watch = FirstWatch("descent")
    rig = _first_course_rig().run(on_tick=watch)
    assert rig.link.results[0].status == "done"
    assert watch.guarded
    assert watch.relooks_at_release == MAX_RELOOKS
    assert rig.uav.attempt.place_attempts == 0
    assert watch.release_age_s is not None and watch.release_age_s > UavConfig.release_fresh_s


def test_a_first_course_brick_whose_neighbour_was_never_seen_is_placed_as_before() -> None:
    """The neighbour is in the blueprint but never in view in this placement (not built yet, or out of the
    camera's view): nothing to see again from above, no look back up."""
    watch = FirstWatch("never")
    rig = _first_course_rig().run(on_tick=watch)
    assert rig.link.results[0].status == "done"
    assert not watch.guarded and rig.uav._gate.relooks == 0
    assert watch.release_age_s == math.inf


def test_the_bricks_it_stands_on_outweigh_the_rest_of_the_wall() -> None:
    """A tower's third brick sees its support and the tower's first brick: only the support counts."""
    wall = {0: (0.0, 0.0, 0.1), 1: (0.0, 0.0, 0.2), 2: (0.0, 0.0, 0.3), 5: (0.6, 0.0, 0.3)}
    size = (0.30, 0.15, 0.10)
    near = supports_of(wall, 2, size)
    assert near == {1}
    seen = {0: np.array([0.0, 0.0, 0.1]), 1: np.array([0.12, 0.0, 0.2])}  # the support built 12 cm off
    assert np.allclose(wall_offset_m(seen, wall, 2, near), [0.12, 0.0, 0.0])
    assert np.allclose(wall_offset_m(seen, wall, 2), [0.06, 0.0, 0.0])  # (the mean of all, as before)
    assert np.allclose(wall_offset_m({0: seen[0]}, wall, 2, near), [0.0, 0.0, 0.0])  # none near: the rest
    assert math.isclose(float(np.linalg.norm(wall_offset_m(seen, wall, 2, near))), 0.12)


def test_it_is_on_by_default_with_the_wall_alignment_and_uav_yaml_may_switch_it_off() -> None:
    assert (
        UavConfig("b", "brick", (0.0, 0.0, 0.0)).release_fresh_s == 0.45
    )  # (it acts only with align_on_wall)
    assert uav_settings("px4", {"release_fresh_s": 0})["release_fresh_s"] == 0
    assert "release_fresh_s" not in uav_settings("arducopter")


class LegWatch:
    """The support hidden for the first descent (as ``Watch("once")``); where the UAV was when its first look back
    up began and where it let go."""

    def __init__(self) -> None:
        self.look_m: np.ndarray | None = None
        self.release_m: np.ndarray | None = None

    def __call__(self, rig: Rig) -> None:
        uav = rig.uav
        hidden = uav.state == "place_descend" and uav._gate.relooks == 0
        rig.camera.hidden = frozenset({2 * SUPPORT, 2 * SUPPORT + 1}) if hidden else frozenset()
        here = None if uav._tel is None else np.asarray(uav._tel.position_m, dtype=float)
        if self.look_m is None and uav._gate.looking:
            self.look_m = here
        if self.release_m is None and uav.state == "place_release":
            self.release_m = here


def test_a_stale_offset_at_the_end_of_the_side_looks_descent_is_looked_at_again_before_the_last_leg() -> None:
    """With the side look the descent ends displaced beside the drop-off; the support out of view all the way
    down, the UAV looks back up from there, not after a last leg flown sideways on the stale offset (which on GNSS
    took px4 rotated bond seed 12's B8 under its supports' tops, a course low; tests/test_side_look.py)."""
    watch = LegWatch()
    rig = _rig(side_look=True).run(on_tick=watch)
    assert rig.link.results[0].status == "done"
    assert rig.uav._side.offset_m is not None  # a displaced descent (15 cm beside the drop-off here)
    assert watch.look_m is not None and watch.release_m is not None
    # the look began at the pre-release point, beside the drop-off (before: at the drop-off, 0.5 mm from it)
    assert float(np.linalg.norm((watch.look_m - watch.release_m)[:2])) > 0.1


def _closing_case(
    error_m: tuple[float, float],
    velocity_mps: tuple[float, float],
    seen_ago_s: float,
    last_leg: bool = True,
    past_end_s: float = 5.0,
    guarded: bool = False,
    bricks: int = 0,
) -> bool:
    """ReleaseGate.closing on one tick: the effector ``error_m`` off its target, moving at ``velocity_mps``, the
    wall last seen ``seen_ago_s`` before, on the side look's last leg or not, ``past_end_s`` after the descent's
    leg ended (5 s: past the hold), the drop-off guarded (on bricks of the wall) or not, ``bricks`` in the
    blueprint, the px4 preset's settings."""
    wall = tuple((i, (0.3 * i, 0.0, 0.05, 0.0)) for i in range(bricks))
    cfg = UavConfig("b", "brick", (0.0, 0.0, 0.0), **{**uav_settings("px4"), "wall": wall})
    target = np.array([1.0, 2.0, 0.3])
    tel = SimpleNamespace(velocity_mps=(velocity_mps[0], velocity_mps[1], 0.0))
    uav = SimpleNamespace(
        config=cfg,
        _now_s=10.0,
        _wall=SimpleNamespace(seen_s=10.0 - seen_ago_s),
        _side=SimpleNamespace(final=last_leg),
        nav=SimpleNamespace(end_s=10.0 - past_end_s),
        effector=SimpleNamespace(position=lambda _tel: target + np.array([error_m[0], error_m[1], 0.0])),
        attempt=SimpleNamespace(place_effector_target_m=target),
    )
    gate = ReleaseGate()
    gate.guarded = guarded
    return gate.closing(cast("BrickUav", uav), cast("Telemetry", tel))


def test_inside_r_pl_the_last_leg_waits_a_tick_only_while_it_closes_and_the_sighting_stays_fresh() -> None:
    # 12 mm short of the drop-off at 0.1 m/s toward it: 2 mm off the next tick, so wait
    assert _closing_case((-0.012, 0.0), (0.1, 0.0), seen_ago_s=0.2)
    # the same at 0.27 m/s: passing through, 15 mm past by the next tick: let go now
    assert not _closing_case((-0.012, 0.0), (0.27, 0.0), seen_ago_s=0.2)
    # moving away, or across: let go now
    assert not _closing_case((0.005, 0.0), (0.1, 0.0), seen_ago_s=0.2)
    assert not _closing_case((0.0, 0.01), (0.1, 0.0), seen_ago_s=0.2)
    # closing, but the next tick would be past the sighting's freshness (0.45 s): let go now, no look back up
    assert not _closing_case((-0.012, 0.0), (0.1, 0.0), seen_ago_s=0.4)
    # never seen (a first-course brick): as before
    assert not _closing_case((-0.012, 0.0), (0.1, 0.0), seen_ago_s=math.inf)
    # not the side look's last leg (a descent from above): as before
    assert not _closing_case((-0.012, 0.0), (0.1, 0.0), seen_ago_s=0.2, last_leg=False)


def test_the_nearest_tick_is_the_px4_presets_and_off_by_default() -> None:
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).release_closest_s == 0.0
    assert uav_settings("px4")["release_closest_s"] == 0.1
    assert "release_closest_s" not in uav_settings("arducopter")


def test_with_the_wall_in_view_a_release_outside_the_hold_radius_waits_for_a_nearer_tick() -> None:
    # the px4 preset: inside r_pl (1.5 cm) but 1.2 cm off, at rest, the wall seen this tick, 1 s past the leg's
    # end: wait (a calm px4 release let go at r_pl's edge put the surveyed pyramid's B7 2 cm off its neighbours)
    for last_leg in (True, False):
        assert _closing_case((-0.012, 0.0), (0.0, 0.0), seen_ago_s=0.0, last_leg=last_leg, past_end_s=1.0)
        # within the hold radius (1 cm): let go (nothing closing)
        assert not _closing_case((-0.009, 0.0), (0.0, 0.0), seen_ago_s=0.0, last_leg=last_leg, past_end_s=1.0)
        # past the hold (3.5 s after the leg's end): let go, as before
        assert not _closing_case((-0.012, 0.0), (0.0, 0.0), seen_ago_s=0.0, last_leg=last_leg, past_end_s=3.6)
        # the wall out of view since an earlier tick (the side look's last leg hides it): no hold, the sighting
        # ages while it waits
        assert not _closing_case((-0.012, 0.0), (0.0, 0.0), seen_ago_s=0.2, last_leg=last_leg, past_end_s=1.0)
    # a lone brick (issue 29's scenario: no brick of the wall seen, none under it): its drop-off is the design's,
    # nothing ages while it waits, so it waits as with the wall in view (it let go at r_pl's edge: 20.6 mm off on
    # the real PX4, the carry offset added)
    assert _closing_case((-0.012, 0.0), (0.0, 0.0), seen_ago_s=math.inf, last_leg=False, past_end_s=1.0)
    assert not _closing_case((-0.009, 0.0), (0.0, 0.0), seen_ago_s=math.inf, last_leg=False, past_end_s=1.0)
    assert not _closing_case((-0.012, 0.0), (0.0, 0.0), seen_ago_s=math.inf, last_leg=False, past_end_s=3.6)
    # a wall's first brick, others in the blueprint: no hold (its 3.5 s took the release window from the windowed
    # height test: the px4 rotated bond's first course failed three descents in a row, tests/test_side_look.py)
    assert not _closing_case(
        (-0.012, 0.0), (0.0, 0.0), seen_ago_s=math.inf, last_leg=False, past_end_s=1.0, bricks=3
    )
    # a drop-off on bricks of the wall not yet seen waits for its sighting instead (ReleaseGate.allows)
    assert not _closing_case((-0.012, 0.0), (0.0, 0.0), seen_ago_s=math.inf, past_end_s=1.0, guarded=True)
    cfg = UavConfig("b", "brick", (0.0, 0.0, 0.0))
    assert cfg.release_hold_m == 0.0 and cfg.release_hold_s == 0.0  # off by default
    assert uav_settings("px4")["release_hold_m"] == 0.010 and uav_settings("px4")["release_hold_s"] == 3.5
    assert "release_hold_m" not in uav_settings("arducopter")


class PassWatch:
    """The support in view but on the side look's last leg (every pass blind from its start, the px4 towers' case
    from 7.6 cm out): the age of the wall's sighting as each look back up begins, and the looks at the release."""

    def __init__(self) -> None:
        self.look_ages_s: list[float] = []
        self.release_age_s: float | None = None
        self.relooks_at_release: int | None = None

    def __call__(self, rig: Rig) -> None:
        uav = rig.uav
        gate = uav._gate
        blind = uav.state == "place_descend" and uav._side.final and not gate.looking
        rig.camera.hidden = frozenset({2 * SUPPORT, 2 * SUPPORT + 1}) if blind else frozenset()
        if gate.relooks > len(self.look_ages_s):
            self.look_ages_s.append(uav._now_s - uav._wall.seen_s)
        if uav.state == "place_release" and self.release_age_s is None:
            self.release_age_s = uav._now_s - uav._wall.seen_s
            self.relooks_at_release = gate.relooks


def test_a_side_look_pass_that_misses_is_looked_again_as_the_sighting_goes_stale() -> None:
    """On the side look's last leg the UAV looks back up as soon as the sighting is older than
    ``release_fresh_s``, not when the effector, flying on blind, comes within r_pl (here at the 1.2 s leg's end,
    the sighting about 1 s old); that descent has ``MAX_LEG_LOOKS`` looks, then the stale release as before."""
    watch = PassWatch()
    rig = _rig(side_look=True).run(on_tick=watch)
    uav = rig.uav
    assert uav._side.offset_m is not None  # the support is hidden from above: the side look flew
    assert rig.link.results[0].status == "done"
    assert MAX_LEG_LOOKS > MAX_RELOOKS
    assert watch.relooks_at_release == MAX_LEG_LOOKS
    assert len(watch.look_ages_s) == MAX_LEG_LOOKS
    period = rig.config.control_period_s
    fresh = rig.config.release_fresh_s
    assert all(fresh < age <= fresh + 2 * period for age in watch.look_ages_s), watch.look_ages_s
    assert uav.attempt.place_attempts == 0  # no descent failed
    assert watch.release_age_s is not None and watch.release_age_s > fresh


def test_after_the_side_looks_looks_a_pass_staler_than_the_bound_flies_the_descent_again(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The case above with the bound under the pass's arrival (about 1 s after its sighting here, on the real PX4
    and the px4 model up to 4.2 s: the towers' 84.8 mm brick, the case study's 13.8-20.7 mm ones): after the looks,
    a pass whose sighting is older than ``LAST_PASS_STALE_S`` fails the descent, which is flown again from the
    alignment with new looks; in the last descent allowed the brick is let go as before (not a failed task)."""
    assert LAST_PASS_STALE_S == 1.0
    monkeypatch.setattr(release_gate, "LAST_PASS_STALE_S", 0.6)
    watch = PassWatch()
    rig = _rig(side_look=True).run(on_tick=watch)
    uav = rig.uav
    assert rig.link.results[0].status == "done"
    assert uav.attempt.place_attempts == rig.config.max_place_attempts - 1  # two descents failed so
    assert watch.relooks_at_release == MAX_LEG_LOOKS
    assert watch.release_age_s is not None and watch.release_age_s > 0.6


def _low_case(below_m: float, seen_ago_s: float, guarded: bool = True) -> bool:
    """ReleaseGate.low on one tick: the effector ``below_m`` under its drop-off's height, the wall last seen
    ``seen_ago_s`` before, the drop-off guarded or not, the px4 preset's settings."""
    cfg = UavConfig("b", "brick", (0.0, 0.0, 0.0), **uav_settings("px4"))
    target = np.array([1.0, 2.0, 0.3])
    uav = SimpleNamespace(
        config=cfg,
        _now_s=10.0,
        _wall=SimpleNamespace(seen_s=10.0 - seen_ago_s),
        effector=SimpleNamespace(position=lambda _tel: target - np.array([0.004, 0.0, below_m])),
        attempt=SimpleNamespace(place_effector_target_m=target),
    )
    gate = ReleaseGate()
    gate.guarded = guarded
    return gate.low(cast("BrickUav", uav), cast("Telemetry", SimpleNamespace()))


def test_an_effector_under_its_supports_tops_on_a_fresh_sighting_is_not_let_go() -> None:
    """The px4 rotated bond in 4 m/s, seed 5: the side look's last leg sank 7 cm in a gust and B11, let go 6.8 cm
    below its drop-off, rested a course low; a brick set down from above stays within 2 cm of it."""
    assert _low_case(0.068, seen_ago_s=0.2)
    assert _low_case(LOW_M + 0.001, seen_ago_s=0.0)
    # within LOW_M below, level, or above (the windowed height test judges that): let go
    for below_m in (LOW_M - 0.001, 0.0, -0.02):
        assert not _low_case(below_m, seen_ago_s=0.2)
    # the drop-off's height not measured on the wall now (a stale sighting, or a drop-off on the ground, not
    # guarded: its height is the GNSS's, wandering centimetres): as before
    assert not _low_case(0.068, seen_ago_s=1.0)
    assert not _low_case(0.068, seen_ago_s=math.inf, guarded=False)


def _wide_case(
    error_m: float,
    relooks: int = 0,
    last_leg: bool = True,
    guarded: bool = True,
    in_wind: bool = False,
    ahead_s: float = 0.0,
    velocity_mps: tuple[float, float] = (0.0, 0.0),
    **config: object,
) -> bool:
    """ReleaseGate.wide on one tick: the effector ``error_m`` beside its drop-off, after ``relooks`` looks back
    up, on the side look's last leg or not, the drop-off guarded or not, the placement in a wind or not, the px4
    preset's settings with ``release_leg_m`` 1 cm (the preset's, as the test below checks; ``config`` on
    top)."""
    cfg = UavConfig(
        "b", "brick", (0.0, 0.0, 0.0), **{**uav_settings("px4"), "release_leg_m": 0.010, **config}
    )
    target = np.array([1.0, 2.0, 0.3])
    uav = SimpleNamespace(
        config=cfg,
        _now_s=10.0,
        _wall=SimpleNamespace(seen_s=9.7),
        _side=SimpleNamespace(final=last_leg, offset_m=np.array([-0.13, -0.075, 0.0])),
        effector=SimpleNamespace(
            position=lambda _tel: target + np.array([0.6 * error_m, -0.8 * error_m, 0.0])
        ),
        attempt=SimpleNamespace(place_effector_target_m=target, in_wind=in_wind),
    )
    gate = ReleaseGate()
    gate.guarded, gate.relooks, gate.ahead_s = guarded, relooks, ahead_s
    tel = SimpleNamespace(velocity_mps=np.array([*velocity_mps, 0.0]))
    return gate.wide(cast("BrickUav", uav), cast("Telemetry", tel))


def test_in_calm_air_a_last_leg_tick_wide_of_the_drop_off_is_passed_over_while_looks_are_left() -> None:
    """The px4 towers in calm air: the side look's last leg crosses the 1.5 cm disc at 0.2-0.4 m/s as the
    support's sighting goes stale, and the first tick inside was let go anywhere in it (4 of 60 bricks over 2 cm
    of their neighbours on seeds 0-9, 4 on 10-19; with the rule 0 and 0: docs/performance/as-built.md, branch
    release35). With ``release_leg_m`` 1 cm only a tick within 1 cm is, while a look back up is left to fly the pass
    again."""
    assert _wide_case(0.012)
    assert _wide_case(0.0101, relooks=MAX_LEG_LOOKS - 1, release_leg_looks=0)
    # within 1 cm: let go (the other rules still apply)
    assert not _wide_case(0.009)
    # the last look's pass: let go within r_pl, as before (not a stale release after it)
    assert not _wide_case(0.012, relooks=MAX_LEG_LOOKS)
    # not the side look's last leg (a descent from above, the support in view), or not on bricks of the wall
    assert not _wide_case(0.012, last_leg=False)
    assert not _wide_case(0.012, guarded=False)
    # in a wind: ``release_leg_wind_m`` instead (the test below)
    assert not _wide_case(0.012, in_wind=True, release_leg_wind_m=0.0)
    # off by default and in the arducopter preset; the px4 preset's (branch towers38, out again after one failure of
    # the real PX4's one-brick scenario, whose lone drop-off the rule never judges, and back on branch px439: the real
    # PX4's case study rested its bricks within r_pl of wherever the gate let go: docs/performance/autopilots.md)
    assert not _wide_case(0.012, release_leg_m=0.0)
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).release_leg_m == 0.0
    assert uav_settings("px4")["release_leg_m"] == 0.010
    assert uav_settings("px4")["release_leg_looks"] == 10
    assert "release_leg_m" not in uav_settings("arducopter")


def test_in_a_wind_a_last_leg_tick_wide_of_the_drop_off_is_passed_over_for_the_first_looks() -> None:
    """The px4 rotated bond in 4 m/s (seeds 0-9): of its 4 bricks over 2 cm of their neighbours, three were let go
    on the side look's last leg at a tick the gate itself measured 13-14 mm off the drop-off, a fresh sighting and
    looks back up left (issue 30, branch ``bond41``). ``release_leg_wind_m`` judges such a tick in a wind as
    ``release_leg_m`` does in calm air, for the same first ``release_leg_looks`` looks; the tick itself (no timed
    release in a wind)."""
    assert _wide_case(0.012, in_wind=True, release_leg_wind_m=0.010)
    assert not _wide_case(0.009, in_wind=True, release_leg_wind_m=0.010)
    # its own threshold, not calm air's
    assert not _wide_case(0.012, in_wind=True, release_leg_m=0.02, release_leg_wind_m=0.0)
    assert _wide_case(0.012, in_wind=True, release_leg_m=0.0, release_leg_wind_m=0.010)
    assert not _wide_case(0.012, in_wind=False, release_leg_m=0.0, release_leg_wind_m=0.010)
    # the first release_leg_looks looks only, the last look's pass let go within r_pl
    assert not _wide_case(0.012, in_wind=True, relooks=10, release_leg_wind_m=0.010)
    assert not _wide_case(
        0.012, in_wind=True, relooks=MAX_LEG_LOOKS, release_leg_looks=0, release_leg_wind_m=0.01
    )
    # off by default
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).release_leg_wind_m == 0.0
    assert "release_leg_wind_m" not in uav_settings("arducopter")
    assert "release_leg_wind_m" not in uav_settings("px4")  # a switch: the towers lose on seeds 0-9


def test_a_timed_release_is_judged_wide_at_its_predicted_instant() -> None:
    """With the release timed inside the tick (``ReleaseGate.ahead``), ``release_leg_m`` judges the pass's predicted
    nearest point, not the tick: a tick 1.2 cm out whose pass comes within 1 cm in the coming tick is let go there,
    and one whose pass stays wide is passed over (issue 30, branch ``towers38``)."""
    # the tick 12 mm out along (0.6, -0.8); 0.3 m/s back towards the drop-off for 0.04 s: 0 mm then
    assert not _wide_case(0.012, ahead_s=0.04, velocity_mps=(-0.18, 0.24))
    # the same tick, the pass across it (1.2 cm wide at its nearest): passed over
    assert _wide_case(0.012, ahead_s=0.04, velocity_mps=(0.24, 0.18))
    # not timed (ahead_s 0): the tick as before
    assert _wide_case(0.012, velocity_mps=(-0.18, 0.24))


def test_release_leg_looks_bounds_the_looks_the_rule_holds_for() -> None:
    """``release_leg_looks``: the rule for the first that many looks back up only, later passes let go within r_pl
    (0: all of them but the last look's, as before)."""
    assert _wide_case(0.012, relooks=4, release_leg_looks=5)
    assert not _wide_case(0.012, relooks=5, release_leg_looks=5)
    assert _wide_case(0.012, relooks=MAX_LEG_LOOKS - 1, release_leg_looks=0)


def test_a_lone_brick_is_not_judged_by_release_leg_m() -> None:
    """Issue 29's one-brick scenario (``tests/test_px4_sitl.py``): its drop-off stands on the ground with no brick of
    the wall about it, so its descent is not guarded and ``release_leg_m`` never passes over its passes. On the px4
    model the same flight, to the digit, with the rule and without (the real PX4's scenario failed once with it in
    the preset, "drop-off of B1 not reached within 1.5 cm after 3 descents": not the rule's; branch px439)."""
    bp = parse_blueprint(yaml.safe_load(ONE_BRICK))
    flown = {}
    for leg_m in (0.0, 0.010):
        settings = {**uav_settings("px4"), "release_leg_m": leg_m, "release_leg_looks": 10}
        config = UavConfig("template", "brick", (0.0, 0.0, 0.0), **settings)
        report = simulate(bp, seed=1, vehicle="px4", uav_config=config)
        assert report.completed
        flown[leg_m] = (report.placement_error_m, report.makespan_s)
    assert flown[0.0] == flown[0.010]


def test_a_timed_release_is_predicted_no_farther_ahead_than_the_ticks_come() -> None:
    """The real PX4's last leg ticks at 20 Hz: a release predicted 0.096 s ahead there let go 29 mm from where it was
    predicted, the telemetry's velocity trailing the accelerating pass (branch px439); the next tick predicts it
    again. A simulated mission's 0.1 s ticks keep the preset's 0.1 s."""
    assert release_gate.reach_s(0.1, 0.05) == 0.05
    assert release_gate.reach_s(0.1, 0.1) == 0.1
    assert release_gate.reach_s(0.1, 0.0999999) == 0.1  # (a simulated clock's rounding: the same tick)
    assert release_gate.reach_s(0.1, 0.3) == 0.1  # a stalled tick: the preset's
    assert release_gate.reach_s(0.1, math.inf) == 0.1  # the first tick
