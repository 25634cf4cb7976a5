"""The states both UAV machines share: idle, takeoff, home, land, failsafe, emergency and halted.

Each state is an ``enter_<state>`` callback (its motion and actuators) and a ``do_<state>`` tick handler (which
fires the state's trigger when its work is done), as declared in :mod:`masonry.fsm.states`. The gate states'
declared exit checks (:mod:`masonry.fsm.gates`: the swing gate) run from here too (:meth:`CommonStates._gate_failure`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from masonry.errors import HardwareError
from masonry.fsm.attempt import Swing, Takeoff
from masonry.fsm.first_hover import FirstHover
from masonry.fsm.hover_gains import derive_gains
from masonry.fsm.taskbook import TaskBook
from masonry.fsm.watchdogs import taken_over
from masonry.motion import PID, PIDGains
from masonry.ports import BATTERY_LOW_REASON, Telemetry

log = logging.getLogger(__name__)
#: The takeoff is over this close under its altitude (the autopilot flies it; the machine then takes over) ...
_TAKEOFF_SHORT_M = 0.1
#: ... once climbing slower than this: an autopilot that shapes its climb (ArduCopter's PSC_JERK_Z) and was taken
#: over at 0.48 m/s rose 0.12 m past the layer its pad's column reaches (issue 19)
_TAKEOFF_SETTLE_MPS = 0.2
#: The least climb a take-off asks for (m), where the transit altitude is lower over the ground.
_TAKEOFF_MIN_CLIMB_M = 0.3
#: Disarmed on the ground this long after a take-off was asked for: arm and ask again, at most this often.
_TAKEOFF_RETRY_S = 2.0
_TAKEOFF_RETRIES = 2
_TAKEOFF_STUCK_S = 6.0


class CommonStates(TaskBook):
    """The callbacks of the states every UAV has (see the module's docstring)."""

    #: The velocity axes the swing gate's running mean counts: those the guarded states' own exit tests judge (3:
    #: the adhesion UAV's hover asks the nozzle still in all three; the brick UAV's alignments are horizontal, 2).
    SWING_AXES = 3

    def _hardware_failure(self, reason: str) -> None:
        state = self.state
        if state == "halted":
            return
        if state == "idle":
            self.halt_reason = reason
            self.retire(reason=reason)
            return
        if state == "emergency":
            if self._now_s - self._entered_s > self.config.link_lost_timeout_s:
                self.giveup(reason=reason)
            return
        self.lost(reason=reason)

    def enter_idle(self, *args: object, **kwargs: object) -> None:
        self._stop()

    def do_idle(self, tel: Telemetry) -> None:
        if not tel.on_ground and tel.armed:
            return  # not ours to fly (should not happen)
        if tel.battery_fraction < self.config.battery_low_fraction and not self._battery_service:
            self.halt_reason = f"{BATTERY_LOW_REASON} ({tel.battery_fraction:.0%})"
            self.retire(reason=self.halt_reason)
            return
        # with a battery service: handed over once the pack is swapped
        task = self._take(self.link.poll_task())
        if task is not None:
            self._start_task(task)
            self.assign(task=task)

    def enter_takeoff(self, *args: object, **kwargs: object) -> None:
        self._stop()
        tel = self._tel
        assert tel is not None
        self.nav.pid.reset()
        ground = self._ask_takeoff(tel, tries=1)
        takeoff = self.attempt.takeoff
        assert takeoff is not None
        x, y, _ = ground.position_m
        # where the autopilot takes it (the machine hovers there next)
        self.nav.expect((x, y, takeoff.target_m))

    def _ask_takeoff(self, tel: Telemetry, tries: int) -> Telemetry:
        """Arm (unless armed) and ask for the take-off to the transit altitude (at least ``_TAKEOFF_MIN_CLIMB_M``
        up), measured from the ground as it is once armed; record it (:class:`Takeoff`). Returns the telemetry
        the ground was measured in.

        The autopilot climbs ``climb_m`` from the ground it has when asked: the MAVLink adapter measures the
        ground again as it arms (its frame moves to it) and climbs from the position at ``takeoff``; a simulated
        vehicle from where it stands. A ground read before an arming that took time (a real autopilot's pre-arm
        checks, the estimate moving meanwhile) was another one: on the real PX4 the climb aimed at 1.09 m while the
        machine waited for 1.10 m (issue 29). So the ground is read once armed, the climb is asked from it and
        ``target_m`` (ground + climb) is what :meth:`do_takeoff` waits for. Armed already, the tick's telemetry is
        the reading of that moment.
        """
        arming_s = self.clock.now_s()
        if not tel.armed:
            self.fc.arm()  # (the MAVLink adapter measures the ground afresh here and moves its frame to it)
            tel = self.fc.telemetry()  # the ground as the autopilot has it once armed
        ground_m = float(tel.position_m[2])
        climb_m = max(_TAKEOFF_MIN_CLIMB_M, self._transit_altitude_m() - ground_m)
        # the flight controller gets what is left of the take-off's time-out (do_takeoff gives it up then), from
        # the state's entry (now on the first try: _record_state stamps it after this enter callback)
        entered_s = self._now_s if tries == 1 else self._entered_s
        spent_s = self._now_s + max(0.0, self.clock.now_s() - arming_s) - entered_s
        self.fc.takeoff(climb_m, timeout_s=max(0.0, self.config.takeoff_timeout_s - spent_s))
        # when it was asked (after the arming, which a real autopilot takes its time over), how often, the climb
        asked_s = self._now_s + max(0.0, self.clock.now_s() - arming_s)
        self.attempt.takeoff = Takeoff(asked_s, tries, climb_m, ground_m + climb_m)
        return tel

    def do_takeoff(self, tel: Telemetry) -> None:
        takeoff = self.attempt.takeoff
        assert takeoff is not None  # asked for on entering takeoff
        if self.first_hover is not None and not self.first_hover.done:
            self._identify_tick(tel)
        elif (
            not tel.on_ground
            and tel.position_m[2] >= takeoff.target_m - _TAKEOFF_SHORT_M
            and abs(tel.velocity_mps[2]) <= _TAKEOFF_SETTLE_MPS
        ):
            if self.config.identify_first_hover and self.first_hover is None:
                self.first_hover = FirstHover(self._now_s, tel.position_m)  # once a flight: its first hover
                self._identify_tick(tel)
            else:
                self.airborne()
        elif tel.on_ground and self._retry_takeoff(tel):
            pass
        elif self._now_s - self._entered_s > self.config.takeoff_timeout_s:
            # the flight controller's own account, where it keeps one (the MAVLink adapter's PX4 climb monitor)
            why = getattr(self.fc, "takeoff_problem", None)
            self.abort(
                reason=f"takeoff did not reach {takeoff.target_m:.2f} m "
                f"within {self.config.takeoff_timeout_s:.0f} s" + (f": {why}" if isinstance(why, str) else "")
            )

    def _identify_tick(self, tel: Telemetry) -> None:
        """The first hover's identification (:mod:`masonry.fsm.first_hover`): its velocity this tick; once over,
        the gains derived from it (:func:`~masonry.fsm.hover_gains.derive_gains`) or the preset's, said in the
        log, and on to the task."""
        hover = self.first_hover
        assert hover is not None
        velocity = hover.command(self._now_s, tel)
        if velocity is not None:
            self.fc.send_velocity(velocity, 0.0)
            return
        tuning = derive_gains(hover.fit())
        self.hover_tuning = tuning
        if tuning.kp is not None and tuning.ki is not None and tuning.lag_s is not None:
            gains = self.config.pid_gains or PIDGains()
            xy = {"kp": tuning.kp, "ki": tuning.ki}
            gains = replace(gains, x=replace(gains.x, **xy), y=replace(gains.y, **xy))
            self.config = replace(self.config, pid_gains=gains, velocity_lag_s=tuning.lag_s)
            self.nav.config = self.config
            self.nav.pid = PID(gains)
            self.nav.velocity_lag_s = self.nav.leg_lag_s = tuning.lag_s
        log.warning("%s: %s", self.config.name, tuning.line())
        self.airborne()

    def _gate_failure(self, tel: Telemetry) -> str | None:
        """The reason to fail a gate state (hover, alignment) now, or None: its declared gates
        (:mod:`masonry.fsm.gates`), in order, once the swing's running mean has this tick's speed.

        The mean squared speed over ``swing_window_s`` (exponentially weighted) runs from the gate state's entry
        and is brought up to date only here: the state's work calls this after its own test has failed.
        """
        swing = self._swing
        if swing.entered_s != self._entered_s:
            swing = Swing(self._entered_s, self._now_s, 0.0)
        dt = self._now_s - swing.tick_s
        speed_sq = sum(float(v) * float(v) for v in tel.velocity_mps[: self.SWING_AXES])
        mean_sq = swing.mean_sq_mps2
        mean_sq += min(1.0, dt / self.config.swing_window_s) * (speed_sq - mean_sq)
        self._swing = Swing(self._entered_s, self._now_s, mean_sq)
        for gate in self.gates:
            if gate.guards(self.state):
                reason = gate.check(self._now_s, tel, self)
                if reason is not None:
                    return reason
        return None

    # -- what the gates read (masonry.fsm.gates.Gated) ----------------------------------------------------
    @property
    def swing(self) -> Swing:
        """The gate state's running mean of the squared speed."""
        return self._swing

    @property
    def leg_end_s(self) -> float:
        """When the motion in hand was planned to end."""
        return self.nav.end_s

    @property
    def hold_target_m(self) -> np.ndarray:
        """The point the UAV flies to (or holds)."""
        return self.nav.target_m

    def _retry_takeoff(self, tel: Telemetry) -> bool:
        """Still on the ground after asking for the take-off: ask again (at most twice), arming first if the
        autopilot disarmed; after ``_TAKEOFF_RETRY_S`` disarmed, ``_TAKEOFF_STUCK_S`` armed (motors spool up
        first: ArduCopter leaves the ground about 3.5 s after arming).

        ArduCopter SITL sometimes armed, acknowledged the take-off and stayed on the ground until its
        DISARM_DELAY (10 s) disarmed it ("Arming motors", "Disarming motors"): the take-off then timed out
        (issue 19).
        """
        takeoff = self.attempt.takeoff
        assert takeoff is not None  # asked for on entering takeoff
        waited = self._now_s - takeoff.asked_s
        if takeoff.tries > _TAKEOFF_RETRIES or waited < (_TAKEOFF_STUCK_S if tel.armed else _TAKEOFF_RETRY_S):
            return False
        log.warning(
            "%s: still on the ground %.1f s after the take-off (%s): asking again",
            self.config.name,
            waited,
            "armed" if tel.armed else "disarmed",
        )
        self._ask_takeoff(tel, tries=takeoff.tries + 1)  # from the ground as it is now (re-armed, maybe)
        return True

    def enter_home(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        home = self.config.home_m
        z = max(self.config.cruise_altitude_m, tel.position_m[2])
        if self.config.lateral_altitude_m is not None or self.clearance is not None:
            z = self.config.cruise_altitude_m  # down from the layer over home (with clearance), then land
        self._route(tel, np.array([home[0], home[1], z]))

    def do_home(self, tel: Telemetry) -> None:
        if tel.on_ground:
            # still on the ground: a task given up before its take-off had lifted it (a recall at once, on
            # the shaped arducopter vehicle): land (disarm) and take off afresh for the next task, since an
            # autopilot ignores velocity setpoints on the ground (it flew "pickup_goto" on its pad for 30 s).
            # Or landed and disarmed by the autopilot's own battery failsafe on the way: landed (it hovered in
            # `home` on the ground for ever, a stalled mission, before)
            self.arrived()
            return
        # A task assigned on the way home turns the UAV back at once (instead of landing, idling and taking
        # off again), unless the UAV is to retire or its battery is low.
        if self._may_take_task(tel):
            task = self._take(self.link.poll_task())
            if task is not None:
                self._start_task(task)
                self.assign(task=task)
                return
        if self._advance(tel):
            self.arrived()

    def enter_land(self, *args: object, **kwargs: object) -> None:
        self._stop()
        self.fc.land()

    def do_land(self, tel: Telemetry) -> None:
        if tel.on_ground:
            if tel.armed:
                self.fc.disarm()
            self._on_landed()
            if self._halt_after_landing is not None:
                self.halt_reason = self._halt_after_landing
            self.landed()

    def _on_landed(self) -> None:
        """Actuators to their resting state after touchdown (subclasses)."""

    def enter_failsafe(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self._safe_actuators()
        self._hold(tel)

    def do_failsafe(self, tel: Telemetry) -> None:
        if tel.battery_fraction < self.config.battery_critical_fraction:
            self._halt_after_landing = f"battery critical ({tel.battery_fraction:.0%})"
            self.lost(reason=self._halt_after_landing)
        else:
            self.recover()

    def _safe_actuators(self) -> None:
        """Make the tool safe after a failure (subclasses: close the valve...)."""

    def enter_emergency(self, *args: object, reason: str = "unrecoverable error", **kwargs: object) -> None:
        self._stop()
        self.halt_reason = reason
        try:
            self._safe_actuators()
        except HardwareError:
            pass
        tel = self._tel
        # LAND is commanded once. It is tried again only while it has not gone through (rejected, unanswered,
        # link down) and the autopilot is still in the mode it was in here: a pilot who has switched modes
        # (or the autopilot's own failsafe) has the UAV, and masonry never fights a mode change.
        self.failsafe.mode = tel.mode if tel is not None else None
        self.failsafe.land_tried_s = -math.inf
        # the autopilot took the vehicle (its failsafe's RTL, LAND...): not a LAND of masonry's over it either
        self.failsafe.land_pending = not taken_over(self.failsafe)
        if self.failsafe.land_pending:
            self._command_land(tel)

    #: Seconds between tries of a LAND command that did not go through (emergency).
    LAND_RETRY_S = 1.0

    def _command_land(self, tel: Telemetry | None) -> None:
        if tel is not None and (tel.landing or tel.on_ground):
            self.failsafe.land_pending = False  # already landing (the autopilot's failsafe) or down
            return
        self.failsafe.land_tried_s = self._now_s
        try:
            self.fc.land()
        except HardwareError:
            return  # tried again later; meanwhile the autopilot's own failsafe lands it
        self.failsafe.land_pending = False

    def do_emergency(self, tel: Telemetry) -> None:
        if tel.on_ground:
            self.landed()
            return
        fs = self.failsafe
        if not fs.land_pending:
            return
        if tel.landing or tel.mode != fs.mode:
            fs.land_pending = False  # landing, or a pilot took over: never re-send LAND
        elif self._now_s - fs.land_tried_s >= self.LAND_RETRY_S:
            self._command_land(tel)

    def enter_halted(self, *args: object, reason: str | None = None, **kwargs: object) -> None:
        self._stop()
        if self.halt_reason is None:
            self.halt_reason = reason or self._halt_after_landing or "halted"

    def do_halted(self, tel: Telemetry) -> None:
        self._reject_tasks()
