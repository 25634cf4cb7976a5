"""When the brick UAV's grasp has pressed long enough (issue 29's ArduCopter missed first grasp).

The pickup descent (``BrickUav.enter_pickup_descend``) is a minimum-jerk leg of ``descent_duration_s`` to the
effector ``grasp_press_m`` below the brick's top face; the grasp (``do_pickup_grasp``) then held it for
``grasp_dwell_s`` (0.5 s) with the magnet on and climbed, the joint locked: whatever the magnet had not gripped by
then was a miss, found at cruise altitude (``pickup_verify``), and the attempt went back to ``pickup_estimate``
for a second estimate and descent (15 s). On ArduCopter SITL (the ``arducopter`` preset: its velocity response
trails a command by 0.57 s, the z loop's kp is 1 /s) the body is still 1-3 cm above the descent's end point when
the leg ends and closes the rest at about 1.5 cm/s, so the effector was still 1-2 cm above the brick's top when
the 0.5 s dwell ran out, outside the simulated magnet's 1.5 cm contact band (``WorldConfig.contact_band_m``):
``masonry fly --mission`` on two ArduCopter SITLs (benchmarks/bench_arducopter_case_study.py) missed B0's first
grasp in 2 of 6 runs, 9 of 10 after the windowed LinkClock (docs/performance/autopilots.md).

The grasp now ends after the dwell once the magnet reports the brick (``Gripper.is_attached``) or the body is
within ``grasp_press_m + GRASP_REACH_M`` above the descent's end point (the effector within a centimetre of the
top face: on it, whether or not the magnet took it, as an injected grasp failure must still fail), and at the
latest ``grasp_patience_s`` after the dwell. A vehicle that tracks its descent (every integrated simulation) is
on the brick at the dwell's end and its grasps are unchanged.

On a noisy position source (``UavConfig.gate_window_s`` > 0, the ``px4`` preset; issue 29) being low enough is no
sign of contact: on the real PX4 v1.16 SITL the reported position wanders 4-7 cm rms horizontally and a few
centimetres vertically at the bottom of the descent, about a 2 s period, and the magnet grips only with the effector
within the conical guide's 3 cm and the contact band. The grasp ended at the dwell's 0.5 s with the body low enough
and the magnet empty: a miss, a climb, a second estimate and descent (23 s), and three of them in a row failed the
task ("brick 1 not attached after 3 grasps", the CI rehearsal of 2026-12-05). There the grasp presses on until the
magnet reports the brick (``wait_for_contact``), and climbs empty only after the patience (the preset's: a few
periods of the wander), as an injected grasp failure still must.
"""

from __future__ import annotations

__all__ = ["GRASP_REACH_M", "grasp_done"]

#: The effector within this height above the brick's top face counts as on it (inside the simulated magnet's
#: 1.5 cm contact band).
GRASP_REACH_M = 0.01


def grasp_done(
    *,
    pressed_s: float,
    attached: bool,
    above_end_m: float,
    dwell_s: float,
    press_m: float,
    patience_s: float,
    wait_for_contact: bool = False,
) -> bool:
    """Whether the grasp has pressed long enough to climb.

    Args:
        pressed_s: time in the grasp so far (s).
        attached: the gripper reports a brick on the magnet.
        above_end_m: the body's height above the descent's end point (m; positive: above it).
        dwell_s: ``grasp_dwell_s``, the least time on the brick.
        press_m: ``grasp_press_m``, how far below the top face the descent aimed the effector.
        patience_s: ``grasp_patience_s``, how much longer to wait for a body still above the brick.
        wait_for_contact: a noisy position source: only the magnet's report (or the patience) ends the grasp, not
            the body's height.
    """
    if pressed_s < dwell_s:
        return False
    if attached or (not wait_for_contact and above_end_m <= press_m + GRASP_REACH_M):
        return True
    return pressed_s >= dwell_s + patience_s
