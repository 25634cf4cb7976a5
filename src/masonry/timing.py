"""TaskTiming: the durations, speeds and tool geometry of the UAVs' tasks, in one pure value.

Three places need the same numbers: the state machines fly them (``masonry.fsm``, tuned by ``UavConfig``), the
makespan lower bound counts them (:mod:`masonry.planner.bounds`) and mission control's airspace reserves the
altitudes they imply (:mod:`masonry.mission.airspace`). They all read them from a :class:`TaskTiming`
(``UavConfig.timing()``), and ``UavConfig``'s defaults are the defaults declared here, so a change of, say,
``descent_duration_s`` cannot make the bound unsound or the airspace's altitudes differ from the machines'.

The core imports this module, never ``masonry.fsm``: the direction stays core <- fsm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from masonry.airframe import DEFAULT_AIRFRAME, Airframe

Vec3 = tuple[float, float, float]

#: The peak speed of a rest-to-rest minimum-jerk leg is this many times its mean speed. The leg's position is
#: ``d * s(tau)`` with ``s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5``, ``tau = t / T``; its speed
#: ``d / T * s'(tau)``, ``s'(tau) = 30 tau^2 (1 - tau)^2``, peaks at ``tau = 1/2`` where ``s' = 30 / 16 = 1.875``.
#: So a leg of distance ``d`` flown with a peak speed ``v`` lasts ``1.875 d / v`` (:func:`min_jerk_leg_s`).
MIN_JERK_PEAK_TO_MEAN_SPEED = 1.875

#: Each leg of the state machines ends with the UAV brought to rest (below ``arrive_speed_mps``, settled before a
#: transit's request): seconds added to a leg's planned duration (``masonry.fsm.battery`` re-exports it). On the
#: arducopter vehicle a leg took 1-2 s past its plan.
LEG_SETTLE_S = 1.5

#: The state machines never plan a minimum-jerk leg shorter than this (a leg of a few centimetres still settles).
MIN_LEG_S = 1.0


def min_jerk_leg_s(distance_m: float, peak_speed_mps: float, min_s: float = MIN_LEG_S) -> float:
    """How long the state machines make a rest-to-rest minimum-jerk leg of ``distance_m``: its speed peaks at
    ``peak_speed_mps`` (:data:`MIN_JERK_PEAK_TO_MEAN_SPEED`), and it lasts at least ``min_s``."""
    return max(min_s, MIN_JERK_PEAK_TO_MEAN_SPEED * max(distance_m, 0.0) / peak_speed_mps)


@dataclass(frozen=True)
class TaskTiming:
    """What the bound and the airspace must know of how a UAV flies its tasks (SI units; ``UavConfig``'s
    defaults are these).

    Flight: ``control_period_s`` (the machines' tick), ``cruise_speed_mps`` (peak speed of a lateral leg),
    ``vertical_speed_mps`` (peak speed of a climb), ``arrive_tolerance_m`` (a leg is over this close to its end),
    ``clearance_m`` (a carried brick, or the nozzle, keeps this far above the work while moving over it).

    Brick task (paper, Section IV): ``settle_time_s`` hover before estimating, then ``min_estimates`` frames;
    a minimum-jerk descent of ``descent_duration_s`` (t_f) to ``grasp_press_m`` below the brick's top;
    ``grasp_dwell_s`` on it; the release once the effector is within ``placement_radius_m`` (r_pl) of its
    target, then ``release_dwell_s``.

    Adhesion task (paper, Section V): ``stable_time_s`` hover, a descent of ``spray_descent_s`` (or
    ``chain_descent_s`` for a segment starting where the last one ended), the segment at ``spray_speed_mps``,
    ``close_dwell_s`` after closing the valve.

    Tool geometry (body frame FLU, from the airframe): ``effector_offset_m``, ``nozzle_offset_m``, and
    ``spray_height_m``, the nozzle's height above the surface while spraying.
    """

    control_period_s: float = 0.1
    cruise_speed_mps: float = 1.0
    vertical_speed_mps: float = 0.4
    arrive_tolerance_m: float = 0.08
    clearance_m: float = 0.30
    settle_time_s: float = 0.5
    min_estimates: int = 10
    descent_duration_s: float = 7.0
    grasp_press_m: float = 0.005
    grasp_dwell_s: float = 0.5
    placement_radius_m: float = 0.015
    release_dwell_s: float = 0.5
    stable_time_s: float = 1.0
    spray_descent_s: float = 4.0
    spray_speed_mps: float = 0.15
    close_dwell_s: float = 0.3
    chain_descent_s: float = 0.5
    effector_offset_m: Vec3 = DEFAULT_AIRFRAME.effector_offset_m
    nozzle_offset_m: Vec3 = DEFAULT_AIRFRAME.nozzle_offset_m
    spray_height_m: float = DEFAULT_AIRFRAME.spray_height_m

    @classmethod
    def from_config(cls, config: object) -> TaskTiming:
        """The timing of ``config``, a ``masonry.fsm.UavConfig`` (or anything with its field names and an
        ``airframe``); ``UavConfig.timing()`` says the same."""
        airframe: Airframe = config.airframe  # type: ignore[attr-defined]
        values: dict[str, Any] = {name: getattr(config, name) for name in _CONFIG_FIELDS}
        return cls(
            **values,
            effector_offset_m=_vec3(airframe.effector_offset_m),
            nozzle_offset_m=_vec3(airframe.nozzle_offset_m),
            spray_height_m=float(airframe.spray_height_m),
        )

    def carry_altitude_m(self, top_m: float, size_z_m: float) -> float:
        """Body altitude at which a carried brick ``size_z_m`` high clears a brick top at ``top_m`` by
        ``clearance_m`` (the brick UAV's transit altitude over its drop-off, above the cruise altitude)."""
        return top_m - self.effector_offset_m[2] + size_z_m + self.clearance_m

    def spray_altitude_m(self, surface_m: float) -> float:
        """Body altitude at which the nozzle is ``clearance_m`` above its spraying height over a surface at
        ``surface_m`` (the adhesion UAV's transit altitude over its segment, above the cruise altitude)."""
        return surface_m + self.spray_height_m - self.nozzle_offset_m[2] + self.clearance_m


def _vec3(v: tuple[float, ...]) -> Vec3:
    return (float(v[0]), float(v[1]), float(v[2]))


#: The fields of TaskTiming that ``UavConfig`` has under the same name (the rest come from its airframe).
_CONFIG_FIELDS = (
    "control_period_s",
    "cruise_speed_mps",
    "vertical_speed_mps",
    "arrive_tolerance_m",
    "clearance_m",
    "settle_time_s",
    "min_estimates",
    "descent_duration_s",
    "grasp_press_m",
    "grasp_dwell_s",
    "placement_radius_m",
    "release_dwell_s",
    "stable_time_s",
    "spray_descent_s",
    "spray_speed_mps",
    "close_dwell_s",
    "chain_descent_s",
)

#: The timing of a ``UavConfig`` with its defaults (and of the default airframe).
DEFAULT_TIMING = TaskTiming()


def spray_descent_leg_s(drop_m: float, vertical_speed_mps: float, spray_descent_s: float) -> float:
    """How long an adhesion UAV's first descent over a segment's start lasts (issue 27): a minimum-jerk leg of
    ``drop_m`` at the climb's peak speed ``vertical_speed_mps`` (:func:`min_jerk_leg_s`, at least
    :data:`MIN_LEG_S`), at most ``spray_descent_s``. The clearance alone (0.30 m) is 1.4 s at 0.4 m/s, where a
    fixed ``spray_descent_s`` of 4 s held the nozzle at a 0.14 m/s peak; a drop of 0.8 m or more takes all 4 s."""
    return min(spray_descent_s, min_jerk_leg_s(drop_m, vertical_speed_mps))


__all__ = [
    "DEFAULT_TIMING",
    "MIN_JERK_PEAK_TO_MEAN_SPEED",
    "MIN_LEG_S",
    "TaskTiming",
    "min_jerk_leg_s",
    "spray_descent_leg_s",
]
