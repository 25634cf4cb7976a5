"""How far apart UAVs must keep, in the air and on their pads: the numbers the blueprint's validation and
mission control's airspace (``masonry.mission.airspace``) both use, so that what validates can be flown.

- **In the air**: two airborne UAVs in their reserved volumes are at least ``SEPARATION_XY_M`` apart
  horizontally or ``LAYER_SPACING_M`` vertically (the 1 m target plus tracking error; docs/safety.md).
- **On the ground**: a UAV on its pad holds only the pad. Another UAV may take off, land or fly beside it as
  long as their centres stay ``pad_separation_m`` apart: the airframe's span (propeller tip to tip) plus
  ``PAD_MARGIN_M``. Take-offs and landings from neighbouring pads are then sequenced by the airspace (two
  airborne UAVs need the full separation), not forbidden.
- **Pads and work sites**: a pad must be far enough from every pickup, drop-off and the wall that a landed UAV
  never blocks the work there: ``pad_site_distance_m`` (the pad separation plus the work zone's slack).

Pure: no I/O.
"""

from __future__ import annotations

from masonry.airframe import DEFAULT_AIRFRAME, Airframe

#: Horizontal separation between two airborne UAVs' reserved volumes: the 1 m target plus tracking error.
SEPARATION_XY_M = 1.2

#: Vertical distance between two transit layers (and between any two airborne volumes stacked).
LAYER_SPACING_M = 1.1

#: Room between the propeller tips of a landed UAV and one beside it (tracking error at take-off and landing).
PAD_MARGIN_M = 0.2

#: The share of the air separation's tracking error one UAV may use (``SEPARATION_XY_M`` is 1 m and two of them).
TRACK_SHARE_M = 0.1

#: How far a short lateral leg at the autopilot's own limits overshoots its end on the ``arducopter`` vehicle (a
#: 1.3-1.5 m leg, peak 1.1-1.2 m/s^2: 0.112 m): where a leg's end volume has less slack than this beyond the
#: tracking share, the leg is flown within ``UavConfig.zone_leg_accel_mps2`` unless mission control widened that
#: end by the difference (``Grant.gentle`` False: nothing of another UAV's near it; docs/safety.md).
LEG_OVERSHOOT_M = 0.12


def zone_slack_m(clearance_m: float, separation_xy_m: float = SEPARATION_XY_M) -> float:
    """Horizontal slack of a work zone (alignment, the nozzle along its segment): two zones are then the
    blueprint's clearance r_c apart."""
    return max(0.0, (float(clearance_m) - separation_xy_m) / 2.0)


def fast_leg_excess_m(slack_m: float) -> float:
    """How far past its end volume (of horizontal slack ``slack_m``) a leg at the autopilot's own limits may come
    beyond the tracking share: what mission control widens that end by for a leg it lets be flown fast."""
    return max(0.0, LEG_OVERSHOOT_M - TRACK_SHARE_M - float(slack_m))


def pad_separation_m(airframe: Airframe = DEFAULT_AIRFRAME) -> float:
    """Least distance between two pads (homes), centre to centre: the span plus ``PAD_MARGIN_M``."""
    return float(airframe.span_m) + PAD_MARGIN_M


def pad_site_distance_m(clearance_m: float, airframe: Airframe = DEFAULT_AIRFRAME) -> float:
    """Least horizontal distance from a pad to a pickup or to the wall's footprint: a UAV working there (within
    its zone's slack) keeps ``pad_separation_m`` from the landed one."""
    return pad_separation_m(airframe) + zone_slack_m(clearance_m)


__all__ = [
    "LAYER_SPACING_M",
    "LEG_OVERSHOOT_M",
    "PAD_MARGIN_M",
    "SEPARATION_XY_M",
    "TRACK_SHARE_M",
    "fast_leg_excess_m",
    "pad_separation_m",
    "pad_site_distance_m",
    "zone_slack_m",
]
