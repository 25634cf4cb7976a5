"""The UAV model's battery budget in seconds of flight (docs/state-machines.md, "Battery budget").

The drain is measured in the air (:class:`~masonry.fsm.battery.DrainMeter`); these methods turn it, the
navigator's leg durations and the task's geometry into what a task needs, what is left, and why the battery is
short (:func:`masonry.fsm.battery.route_s` and friends do the arithmetic). The brick UAV adds its put-back.
"""

from __future__ import annotations

import math

from masonry.fsm.base import Vec3
from masonry.fsm.battery import TAKEOFF_S, flight_left_s, land_s, route_s
from masonry.fsm.routing import Routing
from masonry.planner.tasks import Task
from masonry.ports import BATTERY_LOW_REASON, Telemetry
from masonry.separation import PAD_MARGIN_M, SEPARATION_XY_M

#: A UAV waiting in the air for clearance gives its task up once the flight left above the critical battery falls
#: under this many times its way out of the task (plus ``battery_return_wait_s``): the estimate's margin.
RESERVE_FACTOR = 1.25


class BatteryBudget(Routing):
    """What a task needs of the battery, what is left, and why it is short (see the module's docstring)."""

    def battery_short(self, tel: Telemetry) -> str | None:
        """Why the battery cannot carry on with the task (None: it can); the reason starts with
        :data:`BATTERY_LOW_REASON` (mission control does not count such a failure as an attempt).

        Below ``battery_low_fraction``; or, waiting in the air for clearance, once the flight left above
        ``battery_critical_fraction`` falls under :data:`RESERVE_FACTOR` times the way out of the task (home, or
        the put-back of a brick) plus ``battery_return_wait_s`` of waiting on it."""
        cfg = self.config
        if tel.battery_fraction < cfg.battery_low_fraction:
            return f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%})"
        drain = self.drain.drain_per_s
        if self._waiting_since_s is None or drain is None:
            return None
        left_s = flight_left_s(tel.battery_fraction, cfg.battery_critical_fraction, drain)
        exit_s, way = self._exit_s(tel)
        if left_s >= RESERVE_FACTOR * exit_s + cfg.battery_return_wait_s:
            return None
        return (
            f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%}): waited {self._now_s - self._waiting_since_s:.0f} s "
            f"for clearance to {self.site_text()}; {left_s:.0f} s of flight left, {way} needs {exit_s:.0f} s"
        )

    # -- the battery budget (masonry.fsm.battery) ---------------------------------------------------------
    def _layer_m(self, start_m: Vec3, end_m: Vec3) -> float:
        """The altitude of a lateral leg between two points, as the budget counts it: the higher of the two (and
        with mission control, at least the cruise altitude: the lowest layer, the one a flight is given when the
        airspace is free; a higher one comes with a wait, which the waiting budget covers), or without mission
        control the UAV's fixed ``lateral_altitude_m``."""
        cfg = self.config
        if self.clearance is None and cfg.lateral_altitude_m is not None:
            return cfg.lateral_altitude_m
        return max(start_m[2], end_m[2], cfg.cruise_altitude_m if self.clearance is not None else -math.inf)

    def _route_s(self, start_m: Vec3, end_m: Vec3) -> float:
        """What the flight from ``start_m`` to ``end_m`` takes with no wait (:func:`masonry.fsm.battery.route_s`)."""

        speed = self.config.layer_vertical_speed_mps  # (the legs as tuples: asked on every tick of a wait)
        return route_s(self.nav.leg_duration_s, speed, start_m, end_m, self._layer_m(start_m, end_m))

    def _home_s(self, from_m: Vec3) -> float:
        """The flight home from ``from_m`` and the landing there."""
        cfg = self.config
        over_home = (cfg.home_m[0], cfg.home_m[1], cfg.cruise_altitude_m)
        return self._route_s(from_m, over_home) + land_s(cfg.cruise_altitude_m - cfg.home_m[2])

    def _exit_s(self, tel: Telemetry) -> tuple[float, str]:
        """What giving the task up now takes, with no wait, and what it is (subclasses: a put-back first)."""
        return self._home_s(tel.position_m), "the way home"

    def _task_flight_s(self, task: Task, from_m: Vec3) -> tuple[float, Vec3]:
        """The flight and work of ``task`` from ``from_m`` with no wait, and where it ends (subclasses)."""
        return 0.0, from_m

    def _wait_budget_s(self) -> float:
        """The waiting for clearance a task is taken with: ``battery_wait_budget_s``, at most the hold patience."""
        cfg = self.config
        patience = math.inf if cfg.hold_patience_s is None else cfg.hold_patience_s
        return min(cfg.battery_wait_budget_s, patience)

    def _flight_need_s(self, task: Task) -> float | None:
        """The flight ``task`` takes from where the UAV is, with no wait: the take-off if on the ground, its
        flight and work, the flight home and the landing (None: no telemetry yet)."""
        tel = self._tel
        if tel is None:
            return None
        flight_s, end_m = self._task_flight_s(task, tel.position_m)
        return (TAKEOFF_S if tel.on_ground else 0.0) + flight_s + self._home_s(end_m)

    def _home_wait_s(self) -> float:
        """The wait for clearance on the way home a task is taken with: none, unless another UAV's pad lies
        within the separation (plus :data:`PAD_MARGIN_M`) of this one's (``neighbour_pad_m``): the columns over
        the two pads then conflict, and this UAV's landing may wait while the other lands, has its pack swapped
        (``battery_swap_s``) and takes off again with its task (it holds its column meanwhile)."""
        cfg = self.config
        if cfg.neighbour_pad_m is None or cfg.neighbour_pad_m >= SEPARATION_XY_M + PAD_MARGIN_M:
            return 0.0
        return land_s(cfg.cruise_altitude_m - cfg.home_m[2]) + cfg.battery_swap_s + TAKEOFF_S

    def task_budget_s(self, task: Task) -> float | None:
        """What ``task`` needs of the battery from where the UAV is, in seconds of flight: its flight with the
        way home (:meth:`_flight_need_s`), the waiting budget (:meth:`_wait_budget_s`) and the wait on the way
        home beside a neighbour's pad (:meth:`_home_wait_s`), the waits cut to what a full pack leaves beside the
        flight (None: no telemetry, or no drain measured yet)."""
        flight_s, drain = self._flight_need_s(task), self.drain.drain_per_s
        if flight_s is None or drain is None:
            return None
        full_s = flight_left_s(1.0, self.config.battery_low_fraction, drain)
        waits_s = self._wait_budget_s() + self._home_wait_s()
        return flight_s + max(0.0, min(waits_s, full_s - flight_s))

    def battery_shortfall(self, task: Task) -> str | None:
        """Why the battery does not cover ``task`` now (the mission handler then holds it for a swap), or None:
        it does, the drain is not measured yet, or not even a full pack would (:meth:`_take` refuses the task).

        Covered: the flight left above ``battery_low_fraction`` at the measured drain is at least
        :meth:`task_budget_s`."""
        tel, drain, low = self._tel, self.drain.drain_per_s, self.config.battery_low_fraction
        need_s = self.task_budget_s(task)
        if tel is None or drain is None or need_s is None or self._pack_too_small(task) is not None:
            return None
        left_s = flight_left_s(tel.battery_fraction, low, drain)
        if left_s >= need_s - 1e-6:
            return None
        return (
            f"battery {tel.battery_fraction:.0%}: {left_s:.0f} s of flight above {low:.0%}, "
            f"task {task.id} needs {need_s:.0f} s"
        )

    def _pack_too_small(self, task: Task) -> str | None:
        """Not even a full pack covers ``task``'s flight from here, with no wait at all (a counted failure: the
        mission stops on it, saying why)."""
        drain, low = self.drain.drain_per_s, self.config.battery_low_fraction
        flight_s = self._flight_need_s(task)
        if drain is None or flight_s is None or flight_s <= flight_left_s(1.0, low, drain):
            return None
        return (
            f"a full battery pack gives {flight_left_s(1.0, low, drain):.0f} s of flight above {low:.0%}; "
            f"task {task.id} needs {flight_s:.0f} s from here (its flight and the way home, with no wait)"
        )
