"""The ``flown`` physical term of the offline schedule (``masonry schedule --physical flown``; docs/schedule.md,
"The physical model", issue 27): each task's duration and site visit as the state machines fly them.

The plain model and the ``visit`` term count every part at its least (:func:`~masonry.planner.bounds.
min_durations_s`, :mod:`~masonry.planner.schedule_visit`): every climb and descent as a bare minimum-jerk leg
between the task's own altitudes. The machines fly more, and mission control's ``site`` rule holds more: a UAV
crosses the airspace at a transit layer (layer 0 at the wall's work altitude, the lowest: ``masonry.mission.
altitudes.layer_base_m``), is granted the flight *down* from it, and requests its next flight once it is back up
at it; and each climb or descent leg of a task ends with the UAV brought to rest (:data:`~masonry.timing.
LEG_SETTLE_S`, the machines' own ``_vertical_s``). The term adds, each from ``TaskTiming`` and the vehicle's
leg limits, never a fitted constant:

* a brick: the descent from layer 0 to its carry altitude over the drop-off, the climb out from the release to
  layer 0 (instead of to the carry altitude), the climb with the brick from the grasp to layer 0 (instead of to
  the carry altitude), each leg settled; the site visit is the flight in from r_c and the align (as ``visit``),
  the descent from the layer, the placing descent, the release dwell and verify, and the climb out to the layer;
* a segment: where it is not chained, its first descent and climb out brought to rest, and the descent from
  layer 0 to its transit altitude and the climb back up, settled (the chain term's first descent and climb out
  grow by them); its visit is its whole duration (as ``visit``) with them.

The term is a model of the mission, not a bound: the layer a flight gets and the waits are the airspace's at run
time, and a UAV given a higher layer flies longer still. docs/performance/fleet.md measures it against the
simulated visits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from masonry.planner.bounds import _min_jerk_time_to_within, flight_slack_m
from masonry.planner.schedule_chain import ChainCosts
from masonry.planner.tasks import AdhesionTask, BrickTask, Task
from masonry.timing import LEG_SETTLE_S, MIN_LEG_S, TaskTiming, min_jerk_leg_s


def _settled(dz_m: float, timing: TaskTiming) -> float:
    """A climb or descent leg of ``dz_m`` as the machines fly it: a minimum-jerk leg at the vertical speed, brought
    to rest (0 for no leg)."""
    return min_jerk_leg_s(dz_m, timing.vertical_speed_mps) + LEG_SETTLE_S if dz_m > 1e-9 else 0.0


def layer0_m(tasks: Sequence[Task], timing: TaskTiming, cruise_altitude_m: float) -> float:
    """Transit layer 0 of a wall of ``tasks`` (done ones too): its work altitude, as ``masonry.mission.altitudes.
    layer_base_m`` counts it (carrying each brick over its drop-off, spraying on its top)."""
    z = float(cruise_altitude_m)
    for t in tasks:
        if isinstance(t, BrickTask):
            top = t.position_m[2] + t.size_m[2] / 2.0
            z = max(z, timing.carry_altitude_m(top, t.size_m[2]), timing.spray_altitude_m(top))
    return z


@dataclass(frozen=True)
class BrickVisit:
    """A brick's site visit as flown (s): from the grant of the flight down to the request to leave."""

    flight_in_s: float  # from r_c (less the arrive slack) to over the drop-off, one minimum-jerk leg
    layer_descent_s: float  # from layer 0 down to the carry altitude over the drop-off, settled
    align_s: float  # the align over the drop-off (one minimum leg)
    placing_s: float  # the placing descent until the effector is within the release radius
    release_s: float  # the release dwell and the verify tick
    climb_out_s: float  # from the release up to layer 0, settled

    @property
    def total_s(self) -> float:
        return (
            self.flight_in_s
            + self.layer_descent_s
            + self.align_s
            + self.placing_s
            + self.release_s
            + self.climb_out_s
        )


def _brick_alts(t: BrickTask, timing: TaskTiming, cruise_altitude_m: float) -> tuple[float, float, float]:
    """The carry altitude over the drop-off, the body's altitude at the release and at the grasp."""
    h = t.size_m[2]
    eff_z = timing.effector_offset_m[2]
    top_drop = t.position_m[2] + h / 2.0
    transit = max(cruise_altitude_m, timing.carry_altitude_m(top_drop, h))
    pickup = t.pickup_m if t.pickup_m is not None else t.position_m
    grasp = max(pickup[2] + h / 2.0, h) - timing.grasp_press_m - eff_z
    return transit, top_drop - eff_z, grasp


def brick_visit(
    t: BrickTask, timing: TaskTiming, cruise_altitude_m: float, layer_m: float, clearance_m: float
) -> BrickVisit:
    """Brick task ``t``'s site visit as flown, its UAV crossing at ``layer_m`` (r_c ``clearance_m``)."""
    transit, release, _grasp = _brick_alts(t, timing, cruise_altitude_m)
    drop = transit - release
    return BrickVisit(
        flight_in_s=min_jerk_leg_s(max(0.0, clearance_m - flight_slack_m(timing)), timing.cruise_speed_mps),
        layer_descent_s=_settled(layer_m - transit, timing),
        align_s=MIN_LEG_S,
        placing_s=timing.descent_duration_s * _min_jerk_time_to_within(drop, timing.placement_radius_m),
        release_s=timing.release_dwell_s + timing.control_period_s,
        climb_out_s=_settled(max(layer_m, transit) - release - timing.placement_radius_m, timing),
    )


def brick_extra_s(t: BrickTask, timing: TaskTiming, cruise_altitude_m: float, layer_m: float) -> float:
    """What brick task ``t`` flies over its minimum duration: the climb with the brick to ``layer_m`` (not the
    carry altitude), the descent from it to the carry altitude, the climb out to it, each leg settled."""
    transit, release, grasp = _brick_alts(t, timing, cruise_altitude_m)
    top = max(layer_m, transit)
    drop = transit - release
    min_climbs = min_jerk_leg_s(transit - grasp, timing.vertical_speed_mps) + min_jerk_leg_s(
        drop - timing.placement_radius_m, timing.vertical_speed_mps
    )
    flown = (
        _settled(top - grasp, timing)
        + _settled(top - transit, timing)
        + _settled(top - release - timing.placement_radius_m, timing)
    )
    return max(0.0, flown - min_climbs)


def segment_layer_s(t: AdhesionTask, timing: TaskTiming, cruise_altitude_m: float, layer_m: float) -> float:
    """A segment's descent from ``layer_m`` to its transit altitude, and its climb back up (each settled), that
    an unchained segment flies besides its first descent and climb out."""
    transit = max(cruise_altitude_m, timing.spray_altitude_m(max(t.start_m[2], t.end_m[2])))
    return _settled(layer_m - transit, timing)


def flown_terms(
    tasks: Sequence[Task],
    all_tasks: Sequence[Task],
    dur: Sequence[int],
    chain: ChainCosts | None,
    timing: TaskTiming,
    cruise_altitude_m: float,
    clearance_m: float,
    tick_s: float,
) -> tuple[list[int], list[int], ChainCosts | None]:
    """Per task its flown duration and visit (ticks, rounded down), and the chain term with the segments'
    layer legs (each way) added to their first descent and climb out."""
    layer = layer0_m(all_tasks, timing, cruise_altitude_m)
    new_dur = list(dur)
    visit = list(dur)
    climb = list(chain.climb) if chain is not None else []
    descend = list(chain.descend) if chain is not None else []
    for i, t in enumerate(tasks):
        if isinstance(t, BrickTask):
            new_dur[i] = math.floor(
                (dur[i] * tick_s + brick_extra_s(t, timing, cruise_altitude_m, layer)) / tick_s
            )
            v = brick_visit(t, timing, cruise_altitude_m, layer, clearance_m).total_s
            visit[i] = min(new_dur[i], math.floor(v / tick_s))
        elif isinstance(t, AdhesionTask) and chain is not None:
            # the first descent and the climb out, each brought to rest, and the layer legs
            leg = math.floor((segment_layer_s(t, timing, cruise_altitude_m, layer) + LEG_SETTLE_S) / tick_s)
            climb[i] += leg
            descend[i] += leg
    new_chain = None if chain is None else ChainCosts(tuple(climb), tuple(descend), chain.follows)
    return new_dur, visit, new_chain


__all__ = ["BrickVisit", "brick_extra_s", "brick_visit", "flown_terms", "layer0_m", "segment_layer_s"]
