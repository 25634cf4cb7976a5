"""The brick UAV's re-seat (issue 30): a brick the as-built look saw out of place is lifted and placed again.

After the release the UAV climbs out with the placed brick under its camera (``place_ascend``,
:mod:`masonry.fsm.as_built`). Once that look's window is full (or the climb is over), the brick's offsets from the
bricks it touches that were seen with it (its course neighbours, its supports) are compared with their designed
offsets: their mean deviation is how far the brick is from its design *relative to its neighbours*, the quantity
``benchmarks/bench_as_built.py`` measures, to camera noise (the position source's error cancels in the same frame).
Farther than ``UavConfig.reseat_over_m``, a placement aligned on the wall (``align_on_wall``, or in a wind:
:mod:`masonry.fsm.wind_lean`; placed again on the absolute position, a brick would be aimed at its design, not at
the neighbours the look judged it by) re-seats it (``reseat``):

- ``reseat_descend``: magnet on, joint unlocked, the effector down onto the brick's top face as the look saw it
  (``grasp_press_m`` into it), the target following the brick in the camera's frames (the as-built look's camera
  stream: the wander of a GNSS position cancels, as the pickup's camera alignment does);
- ``reseat_grasp``: the press of the pickup (the magnet's dwell, the height's run-off waited out);
- ``reseat_ascend``: the climb to the carrying altitude with the joint locked; the brick on the magnet: its yaw on
  the magnet taken again, the placement counters reset, and the placement flown again from ``place_align`` (the
  same alignment and release gate); not on it: the magnet off and the look made again (``place_ascend``): the brick
  was left where it was.

At most ``reseat_max`` times a task. Never on glue that will be closed by the time the brick is pressed again:
mission control's grant of the drop-off says how long the glue under it stays open
(:attr:`~masonry.ports.ClearanceAnswer.open_for_s`); the re-seat is made only if the descent, the press, the climb
and the placement again (as long as the last one took, from ``place_align`` to the release) and
:data:`RESEAT_SLACK_S` fit in it. Never under another brick: the re-seat is part of the task, before it is reported
done, and mission control sends no brick onto one whose task is not done. Nor on a battery that cannot carry it.
The report's ``as_built`` pose says how many times the brick was re-seated (``reseats``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from masonry.fsm.as_built import AsBuiltLook, LooksBack, frame_tags, world_estimate
from masonry.fsm.camera_align import CameraAlign
from masonry.fsm.descent_reach import HeightRunOff
from masonry.fsm.grasp_reach import grasp_done
from masonry.fsm.putback import PutBack
from masonry.geometry import wrap_angle_rad
from masonry.perception.estimation import EstimatorConfig
from masonry.perception.types import AsBuiltPose
from masonry.ports import Camera, ClearanceAnswer, Telemetry

__all__ = ["RESEAT_SLACK_S", "Reseat"]

#: A re-seat is made only if it presses the brick again this long before its glue closes (s), beyond its own time.
RESEAT_SLACK_S = 5.0


class Reseat(PutBack):
    """The brick UAV's re-seat of a brick placed out of place (see the module's docstring)."""

    camera: Camera
    as_built: AsBuiltLook
    _T_body_cam: np.ndarray
    _est_config: EstimatorConfig
    _run_off: HeightRunOff
    reseat: Callable[..., bool]
    touched: Callable[..., bool]
    grasped: Callable[..., bool]
    attached: Callable[..., bool]
    missed: Callable[..., bool]
    #: the placed brick as the camera sees it on the way down onto it
    _reseat_track: CameraAlign | None = None

    def _site_granted(self, answer: ClearanceAnswer) -> None:
        """The drop-off granted: when the glue under the brick closes (by this UAV's clock), if mission control
        says."""
        if self.state == "transport" and answer.open_for_s is not None:
            self.attempt.open_until_s = self._now_s + answer.open_for_s

    def _reseat_now(self, tel: Telemetry, climbed: bool) -> bool:
        """In ``place_ascend``, once the look is full or the climb over: re-seat the brick if it is out of place
        and may be (fires ``reseat``); True if it does."""
        cfg, a, look = self.config, self.attempt, self.as_built
        if a.reseat_judged or cfg.reseat_over_m <= 0.0 or a.reseats >= cfg.reseat_max:
            return False
        if not (
            cfg.align_on_wall or a.in_wind
        ):  # placed on the absolute position: placed again, it would aim
            return False  # at the design, not at the neighbours the look judges it by
        if not climbed and look.window.count < look.window.size:
            return False
        a.reseat_judged = True
        off_m = look.neighbour_deviation_m(self.brick_task)
        if off_m is None or off_m <= cfg.reseat_over_m or look.window.count < 2:
            return False
        if not self._glue_open_for_reseat() or self.battery_short(tel) is not None:
            return False
        top, yaw = look.window.mean()  # (its top-face centre: what the descent comes down onto)
        a.brick_estimate = (np.asarray(top, dtype=float), float(yaw))
        a.reseats += 1
        self.reseat()
        return True

    def _glue_open_for_reseat(self) -> bool:
        """The re-seat presses the brick again before the glue under it closes (no open time said: True)."""
        until_s = self.attempt.open_until_s
        if until_s is None:
            return True
        cfg, t = self.config, self.brick_task
        climb_m = self._transit_altitude_m() - t.position_m[2]
        need_s = (
            cfg.descent_duration_s + cfg.grasp_dwell_s + self._vertical_s(climb_m) + self.attempt.placing_s
        )
        return self._now_s + need_s + RESEAT_SLACK_S <= until_s

    def _as_built_pose(self) -> AsBuiltPose | None:
        """The report's as-built pose of the brick: the look's, with the re-seats made."""
        pose = self.as_built.pose(self.brick_task)
        return (
            replace(pose, reseats=self.attempt.reseats) if pose is not None and self.attempt.reseats else pose
        )

    def _pressed(self, tel: Telemetry) -> bool:
        """A grasp's press is done (the pickup's and the re-seat's; masonry.fsm.grasp_reach): the magnet's dwell on
        the brick, longer while the body is above it or EKF2's height has run off (masonry.fsm.descent_reach)."""
        cfg = self.config
        above_end_m = float(tel.position_m[2] - self.nav.target_m[2])
        if cfg.gate_window_s > 0.0:
            self._run_off.waits(self._now_s, above_end_m, cfg.control_period_s, cfg.leg_timeout_s)
        return grasp_done(
            pressed_s=self._now_s - self._entered_s - self._run_off.waited_s,
            attached=self.gripper.is_attached(),
            above_end_m=above_end_m,
            dwell_s=cfg.grasp_dwell_s,
            press_m=cfg.grasp_press_m,
            patience_s=cfg.grasp_patience_s,
            wait_for_contact=cfg.gate_window_s > 0.0,
        )

    # -- the states ------------------------------------------------------------------------------------------
    def enter_reseat_descend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None and self.attempt.brick_estimate is not None
        cfg = self.config
        top = self.attempt.brick_estimate[0]
        self.gripper.set_joint_locked(False)
        self.gripper.set_magnet(True)
        held = self.nav.target_yaw_rad
        body_yaw = float(tel.attitude_rad[2]) if held is None else held
        grasp = np.array([top[0], top[1], top[2] - cfg.grasp_press_m])
        body = self.effector.body_target(grasp, body_yaw)
        self._fly_to(tel, body, cfg.descent_duration_s, body_yaw, cfg.gate_window_s > 0.0)
        self._reseat_track = CameraAlign()
        self._reseat_track.reset(np.asarray(top, dtype=float))

    def do_reseat_descend(self, tel: Telemetry) -> None:
        self._follow_placed(tel)
        if self._now_s >= self.nav.end_s:
            self.touched()

    def _follow_placed(self, tel: Telemetry) -> None:
        """The descent's target follows the placed brick as the camera sees it (the as-built look's frames)."""
        track, estimate = self._reseat_track, self.attempt.brick_estimate
        if track is None or estimate is None:
            return
        camera = self.camera
        frame = camera.read_as_built() if isinstance(camera, LooksBack) else camera.read()
        tags = frame_tags(frame, camera, self.config.markers)
        seen = world_estimate(
            tags, self.brick_task.marker_ids[0] // 2, tel, self._T_body_cam, self._est_config
        )
        if seen is None:
            return
        delta = track.add(seen[0], self._now_s)
        if delta is not None:
            self.attempt.brick_estimate = (np.asarray(estimate[0], dtype=float) + delta, estimate[1])
            self.nav.shift(delta)

    def enter_reseat_grasp(self, *args: object, **kwargs: object) -> None:
        self._run_off.reset()

    def do_reseat_grasp(self, tel: Telemetry) -> None:
        if self._pressed(tel):
            self.attempt.grasp_yaw_rad = tel.attitude_rad[2]
            self.grasped()

    def enter_reseat_ascend(self, *args: object, **kwargs: object) -> None:
        tel = self._tel
        assert tel is not None
        self.gripper.set_joint_locked(True)
        p = tel.position_m
        self._fly_to(tel, np.array([p[0], p[1], self._transit_altitude_m()]))

    def do_reseat_ascend(self, tel: Telemetry) -> None:
        if not self._advance(tel):
            return
        a = self.attempt
        if self.gripper.is_attached():
            assert a.brick_estimate is not None
            a.carry_yaw_rad = wrap_angle_rad(a.brick_estimate[1] - a.grasp_yaw_rad)
            a.place_attempts = a.release_attempts = 0
            self.attached()
        else:
            self.gripper.set_magnet(False)  # not gripped: the brick is where it was; look at it again
            self.missed()
