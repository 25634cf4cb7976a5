"""The brick UAV's put-back: a task given up with the brick on the magnet puts it back where it was picked up.

Then the task is reported failed, so that mission control re-queues it once the brick is on its pallet again
(docs/state-machines.md, "Putting a brick back"). Two rules keep the battery safe: the put-back happens only if
it is affordable (with ``battery_return_wait_s`` of waiting for clearance on the way), and a put-back waiting for
its pickup's column goes home with the brick while the battery still affords the way. The brick UAV
(:class:`masonry.fsm.brick.BrickUav`) adds the task's own states on top of this layer.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from masonry.errors import HardwareError
from masonry.fsm.attempt import BrickAttempt
from masonry.fsm.base import Vec3
from masonry.fsm.battery import LEG_SETTLE_S, flight_left_s
from masonry.fsm.model import UavModel
from masonry.fsm.states import BRICK_LOADED_STATES
from masonry.fsm.tool import Tool
from masonry.geometry import wrap_angle_rad
from masonry.planner.tasks import BrickTask
from masonry.ports import BATTERY_LOW_REASON, Gripper, Telemetry

#: States in which the brick is (or may be) on the magnet: a task given up there puts it back first.
_LOADED_STATES = frozenset(BRICK_LOADED_STATES)
#: A put-back waiting for its pickup's column goes home with the brick once the flight left above the critical
#: battery falls under this many times the rest of the put-back and the way home.
_PUTBACK_LAST_S_FACTOR = 1.1
#: A brick put back is let go after its descent's time-out only this close (horizontally) to where it was picked
#: up: the retry's estimate hover must still see it.
_PUTBACK_NEAR_M = 0.2


class PutBack(UavModel):
    """The brick UAV's carrying altitude, its way out of a task and its put-back (see the module's docstring)."""

    gripper: Gripper
    effector: Tool
    attempt: BrickAttempt
    released: Callable[..., bool]
    stow: Callable[..., bool]
    #: the put-back's legs that do not depend on where the UAV is, and what they were computed for (_putback_legs)
    _putback_cache: tuple[tuple[object, ...], tuple[Vec3, float, float]] | None = None
    #: the last :meth:`_putback_need_s`: from which point (the same object), with which legs, at which tick, and it
    _putback_need_memo: tuple[Vec3, tuple[Vec3, float, float], float, float] | None = None

    def _new_attempt(self, start_s: float, wait_budget_s: float) -> BrickAttempt:
        return BrickAttempt(start_s=start_s, wait_budget_s=wait_budget_s)

    @property
    def brick_task(self) -> BrickTask:
        assert isinstance(self.task, BrickTask)
        return self.task

    def _transit_altitude_m(self) -> float:
        """Cruise altitude, raised so a carried brick clears the drop-off by ``clearance_m``."""
        if isinstance(self.task, BrickTask):
            return self._carry_altitude_m(self.task)
        return self.config.cruise_altitude_m

    def _carry_altitude_m(self, t: BrickTask) -> float:
        """The transit altitude of brick task ``t``: cruise, raised so the brick clears its drop-off."""
        top_z = t.position_m[2] + t.size_m[2] / 2.0
        return max(
            self.config.cruise_altitude_m,
            top_z - self.effector.offset_body_m[2] + t.size_m[2] + self.config.clearance_m,
        )

    def _vertical_s(self, distance_m: float) -> float:
        """A climb or descent leg of the task (the navigator's rest-to-rest leg), settled."""
        return self.nav.leg_duration_s((0.0, 0.0, 0.0), (0.0, 0.0, abs(distance_m))) + LEG_SETTLE_S

    def _putback_need_s(self, from_m: Vec3) -> float:
        """Putting the brick back from ``from_m`` (the flight to its pickup, the descent, the release, the climb)
        and the way home from there, with no wait."""
        cfg = self.config
        legs = self._putback_legs()
        memo = (
            self._putback_need_memo
        )  # (the battery watch asks twice a tick from the same telemetry's point)
        if memo is not None and memo[0] is from_m and memo[1] is legs and memo[2] == self._now_s:
            return memo[3]
        over, vertical_s, home_s = legs
        need_s = (
            self._route_s(from_m, over) + cfg.descent_duration_s + cfg.release_dwell_s + vertical_s + home_s
        )
        self._putback_need_memo = (from_m, legs, self._now_s, need_s)
        return need_s

    def _putback_legs(self) -> tuple[Vec3, float, float]:
        """Where the put-back's descent starts, the climb back from the pallet and the way home from there: the
        same for every ``from_m`` (the battery watch asks on every tick of a wait), so kept while the brick's
        estimate, the carry yaw and the transit altitude stay."""
        assert self.attempt.brick_estimate is not None
        center, est_yaw = self.attempt.brick_estimate
        key = (
            *(float(c) for c in center),
            est_yaw,
            self.attempt.carry_yaw_rad,
            self._transit_altitude_m(),
            self.config,  # (the same object: compared by identity first)
            self.effector,
        )
        cached = self._putback_cache
        if cached is not None and cached[0] == key:
            return cached[1]
        effector_m, yaw = self._putback_pose()
        body = self.effector.body_target(effector_m, yaw)
        over = (float(body[0]), float(body[1]), self._transit_altitude_m())
        legs = (over, self._vertical_s(over[2] - float(body[2])), self._home_s(over))
        self._putback_cache = (key, legs)
        return legs

    def _flight_left_s(self, floor_fraction: float) -> float | None:
        """Seconds of flight above ``floor_fraction`` at the measured drain (None: not measured yet)."""
        drain = self.drain.drain_per_s
        if self._tel is None or drain is None:
            return None
        return flight_left_s(self._tel.battery_fraction, floor_fraction, drain)

    def _exit_s(self, tel: Telemetry) -> tuple[float, str]:
        """With the brick (maybe) on the magnet and its put-back affordable: the put-back and the way home."""
        if (
            self.state in _LOADED_STATES
            and self.attempt.brick_estimate is not None
            and self._putback_affordable()
        ):
            return self._putback_need_s(tel.position_m), f"putting brick {self.brick_task.brick} back"
        return super()._exit_s(tel)

    def _safe_actuators(self) -> None:
        self.gripper.set_joint_locked(True)  # keep a carried brick; it is put down after landing

    def _on_landed(self) -> None:
        kept = self.attempt.kept_on_board if isinstance(self.task, BrickTask) else ""
        if kept:
            # landed with the brick (``stow``): the ground crew takes it off the magnet and back to its pickup
            # before the task is reported failed, so that no UAV looks for it at its pickup before it is there
            self.attempt.kept_on_board = ""
            brick = self.brick_task.brick
            if self.clearance is not None and self.clearance.return_brick(brick):
                kept += f"; ground crew returned brick {brick} to its pickup"
            else:
                kept += f"; no ground crew: brick {brick} waits on {self.config.name}'s pad for a person"
        self.gripper.set_magnet(False)
        self.gripper.set_joint_locked(True)
        if kept:
            self.fail_task(reason=kept)

    # -- putting a brick back (a task given up with the brick on the magnet) ------------------------------
    def may_put_back(self, *args: object, **kwargs: object) -> bool:
        """The task is given up with the brick on the magnet and its pickup pose known: put it back there
        (else it would come home on the UAV, and the task's retry would not find it on its pallet)."""
        if self.attempt.brick_estimate is None or not self._putback_affordable():
            return False
        try:
            return self.gripper.is_attached()
        except HardwareError:
            return False  # the general abort: failsafe, then home (or the emergency)

    def _may_take_task(self, tel: Telemetry) -> bool:
        """Not on the way home with a brick kept on board: its task is still in hand until it has landed."""
        return not (
            isinstance(self.task, BrickTask) and self.attempt.kept_on_board
        ) and super()._may_take_task(tel)

    def _putback_affordable(self) -> bool:
        """The UAV can put the brick back and fly home before its battery is critical, with
        ``battery_return_wait_s`` of waiting for clearance on the way; else it flies home with the brick."""
        left_s = self._flight_left_s(self.config.battery_critical_fraction)
        if left_s is None or self._tel is None or self.attempt.brick_estimate is None:
            return True
        return left_s >= self._putback_need_s(self._tel.position_m) + self.config.battery_return_wait_s

    def battery_short(self, tel: Telemetry) -> str | None:
        """Also short: about to grasp its brick (``pickup_align``), a UAV whose flight left above
        ``battery_low_fraction`` no longer covers the rest of the task with what is left of the waiting it was
        taken with (the pickup's column kept it waiting) and the way home: it gives the task up before it has a
        brick to put back. Only with a ground crew (``swaps_batteries``): without one, a battery reason retires the
        UAV after landing, and the waiting rule (:meth:`UavModel.battery_short`) keeps it safe anyway."""
        short = super().battery_short(tel)
        if short is not None or self.state != "pickup_align" or not self._battery_service:
            return short
        left_s = self._flight_left_s(self.config.battery_low_fraction)
        rest_s = self._flight_need_s(self.brick_task)
        if left_s is None or rest_s is None:
            return None
        rest_s += max(0.0, self.attempt.wait_budget_s - self.attempt.waited_s)
        if left_s >= rest_s:
            return None
        return (
            f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%}): waited {self.attempt.waited_s:.0f} s for clearance; "
            f"{left_s:.0f} s of flight left, brick {self.brick_task.brick}'s placement needs {rest_s:.0f} s"
        )

    def defer_failure(self, *args: object, reason: str = "unrecoverable error", **kwargs: object) -> None:
        """The task is reported failed once the brick is back on its pallet (mission control then re-queues it
        and no other UAV comes for the brick while this one still carries it)."""
        self.attempt.putback_reason = reason
        self._safe_actuators()

    def _putback_pose(self) -> tuple[np.ndarray, float]:
        """Where the effector puts the brick back (its top face where it was picked up) and the body's yaw."""
        assert self.attempt.brick_estimate is not None
        center, yaw = self.attempt.brick_estimate
        return np.asarray(center, dtype=float), wrap_angle_rad(yaw - self.attempt.carry_yaw_rad)

    def _putback_given_up(self, what: str) -> None:
        self.stow(
            reason=f"{self.attempt.putback_reason}; {what}, brick {self.brick_task.brick} kept on board"
        )

    def keep_brick(self, *args: object, reason: str = "unrecoverable error", **kwargs: object) -> None:
        """Home with the brick on the magnet: the task stays in hand (no UAV is sent for the brick) until it
        has landed and handed the brick over (:meth:`_on_landed`), then it is reported failed with ``reason``."""
        self.attempt.kept_on_board = reason

    def _putback_battery_ok(self, tel: Telemetry) -> bool:
        if tel.battery_fraction >= self.config.battery_critical_fraction:
            return True
        self._halt_after_landing = f"battery critical ({tel.battery_fraction:.0%})"
        self.lost(reason=self._halt_after_landing)
        return False

    def enter_putback_goto(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        effector_m, yaw = self._putback_pose()
        body = self.effector.body_target(effector_m, yaw)
        self._route(tel, np.array([body[0], body[1], self._transit_altitude_m()]), yaw_rad=yaw)

    def do_putback_goto(self, tel: Telemetry) -> None:
        if not self._putback_battery_ok(tel):
            return
        if self._waiting_since_s is not None:
            # waiting for its pickup's column: home with the brick while the battery still affords the way
            # (landing on the pallet at the critical battery loses the brick and the UAV, issue 18)
            left_s = self._flight_left_s(self.config.battery_critical_fraction)
            if left_s is not None and left_s < _PUTBACK_LAST_S_FACTOR * self._putback_need_s(tel.position_m):
                self._putback_given_up(
                    f"{left_s:.0f} s of flight left after waiting "
                    f"{self._now_s - self._waiting_since_s:.0f} s for its pickup's column"
                )
                return
        if self._advance(tel):
            self.arrived()
        elif self._now_s > self.nav.end_s + self.config.leg_timeout_s:
            self._putback_given_up("could not reach its pickup")

    def enter_putback_descend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(False)
        effector_m, yaw = self._putback_pose()
        self._fly_to(tel, self.effector.body_target(effector_m, yaw), self.config.descent_duration_s, yaw)

    def do_putback_descend(self, tel: Telemetry) -> None:
        if not self._putback_battery_ok(tel):
            return
        target_m = self._putback_pose()[0]
        error_m = self.effector.distance_m(tel, target_m)
        # On the pallet a few centimetres off does not matter (the retry estimates the brick's pose again):
        # after the descent's time-out it is let go where it is, if that is within _PUTBACK_NEAR_M of its place
        # (a gust dragged a brick 2 m off its pickup and let it go there: the retries never saw it, issue 18);
        # farther, it waits for the UAV to come back, and at leg_timeout_s lets go anyway (bounded)
        late_s = self._now_s - self.nav.end_s
        p = self.effector.position(tel)
        near = math.hypot(float(p[0]) - target_m[0], float(p[1]) - target_m[1]) <= _PUTBACK_NEAR_M
        if (
            error_m <= self.config.placement_radius_m
            or (late_s > self.config.release_timeout_s and near)
            or late_s > self.config.leg_timeout_s
        ):
            self.reached()

    def enter_putback_release(self, *args: object, **kwargs: object) -> None:
        self.gripper.set_magnet(False)

    def do_putback_release(self, tel: Telemetry) -> None:
        if not self._putback_battery_ok(tel):
            return
        dwell_s = self.config.release_dwell_s
        if self._now_s - self._entered_s < dwell_s:
            return
        if not self.gripper.is_attached():
            self.released()
        elif self._now_s - self._entered_s >= dwell_s * self.config.max_release_attempts:
            self._putback_given_up("the magnet did not let go at its pickup")

    def enter_putback_ascend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        p = tel.position_m
        self._fly_to(tel, np.array([p[0], p[1], self._transit_altitude_m()]))

    def do_putback_ascend(self, tel: Telemetry) -> None:
        if not self._putback_battery_ok(tel):
            return
        if self._advance(tel):
            self.finish(
                reason=f"{self.attempt.putback_reason}; brick {self.brick_task.brick} put back at its pickup"
            )
