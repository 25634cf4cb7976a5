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
) -> bool:
    """Whether the grasp has pressed long enough to climb.

    Args:
        pressed_s: time in the grasp so far (s).
        attached: the gripper reports a brick on the magnet.
        above_end_m: the body's height above the descent's end point (m; positive: above it).
        dwell_s: ``grasp_dwell_s``, the least time on the brick.
        press_m: ``grasp_press_m``, how far below the top face the descent aimed the effector.
        patience_s: ``grasp_patience_s``, how much longer to wait for a body still above the brick.
    """
    if pressed_s < dwell_s:
        return False
    if attached or above_end_m <= press_m + GRASP_REACH_M:
        return True
    return pressed_s >= dwell_s + patience_s
