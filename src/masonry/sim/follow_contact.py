"""A carried brick on a vehicle that follows a real autopilot stays on the bricks it came down on (issue 29).

With a real flight controller and simulated actuators and camera (``masonry fly --fc URL --actuators sim --camera
sim``) the simulated world's vehicle takes the autopilot's reported state at every step
(``SimVehicle.follow``): the world's contacts (``World._contact``: the carried brick held above the bricks under
it) hold it for that step only, and the autopilot's own simulator (PX4's SIH) has no wall to stop it. Its
height wanders: on PX4 v1.16 SITL beside busy processes the effector dipped more than the contact's 6 cm below
the top of the brick it was placing onto, and the world then let the carried brick pass into that brick and
dropped it a course lower at the release (the case study's B0 on B2, "misplaced: 10.2 cm below its course
height", 1 of 3 missions). A real brick stops on the brick under it: for a vehicle that follows telemetry
(``follows_telemetry``) a carried brick is held on any brick its footprint overlaps whose top is below its own
top. The integrated vehicle (every simulated flight) keeps the contact's tolerance: it is held step by step and
never gets there, so its flights are unchanged.
"""

from __future__ import annotations

from masonry.sim.bricks import BrickField, SimBrick
from masonry.sim.settle import LEVEL_TOL_M

__all__ = ["carried_contact_tol_m", "carried_support_m"]


def carried_contact_tol_m(vehicle: object, brick_height_m: float, tol_m: float) -> float:
    """How far above a carried brick's bottom a brick under its footprint still holds it (m): ``tol_m``, or, on a
    vehicle that follows a real autopilot's telemetry, up to the carried brick's own top (less a level's
    tolerance)."""
    if getattr(vehicle, "follows_telemetry", False):
        return max(tol_m, brick_height_m - LEVEL_TOL_M)
    return tol_m


def carried_support_m(
    field: BrickField, vehicle: object, brick: SimBrick, margin_m: float, tol_m: float
) -> float:
    """The height of the highest brick top that holds the carried ``brick`` (its footprint shrunk by ``margin_m``),
    within :func:`carried_contact_tol_m` above its bottom; the ground's where there is none."""
    tol = carried_contact_tol_m(vehicle, brick.size_m[2], tol_m)
    return field.support_under(brick.rect(margin_m), below_z_m=brick.bottom_z_m, tol_m=tol)
