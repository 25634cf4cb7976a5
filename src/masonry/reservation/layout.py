"""The site layout the reservation model's deadlock-freedom rests on (pure: no I/O).

A UAV may stay, open-ended, on its pad, at its own parking spot or at a site. For every UAV at a site to be able
to go home whatever the others hold (docs/safety.md, "The space-time reservation model"), pads and parking spots
must never be in anyone's way: :func:`layout_problems` lists what breaks that.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from masonry.reservation.space import DEFAULT_SEPARATION, Separation, Volume, column, pad
from masonry.segments import XY


def layout_problems(
    homes: Mapping[str, XY],
    zones: Sequence[Volume],
    layers_m: Sequence[float],
    *,
    parking: Mapping[str, XY] | None = None,
    separation: Separation = DEFAULT_SEPARATION,
) -> list[str]:
    """What keeps this layout from the model's guarantee, one line each (empty: nothing).

    Args:
        homes: each UAV's pad; parking: each UAV's own parking spot (none by default).
        zones: every work zone a UAV may stay in (``Work.zone()`` of every task).
        layers_m: the transit layers.

    The conditions: pads and parking spots keep the pad separation from each other; the column over each of them
    (a take-off or landing, up to the highest layer) keeps the separation from every work zone; every layer clears
    every zone and every landed UAV vertically. Then no stay at a pad or a parking spot is ever in a flight's way, and no flight's leg
    in any stay's way.
    """
    places = [(f"{u}'s pad", xy) for u, xy in homes.items()]
    places += [(f"{u}'s parking spot", xy) for u, xy in (parking or {}).items()]
    top_m = max(layers_m, default=0.0)
    out: list[str] = []
    for i, (name, xy) in enumerate(places):
        for other, oxy in places[i + 1 :]:
            if separation.conflict(pad(xy), pad(oxy)):
                out.append(f"{name} and {other} are closer than the pad separation {separation.pad_m:.2f} m")
        for k, zone in enumerate(zones):
            if separation.conflict(column(xy, 0.0, top_m), zone):
                out.append(f"{name} at {xy} is within the separation of work zone {k} at {zone.a}")
    for k, zone in enumerate(zones):
        low = [z for z in layers_m if z - zone.z1_m < separation.z_m]
        if low:
            out.append(
                f"layer {low[0]} m is less than {separation.z_m} m over work zone {k} ({zone.z1_m} m high)"
            )
    landed_m = pad((0.0, 0.0)).z1_m
    low = [z for z in layers_m if z - landed_m < separation.z_m]
    if places and low:
        out.append(f"layer {low[0]} m is less than {separation.z_m} m over a landed UAV ({landed_m} m high)")
    return out


__all__ = ["layout_problems"]
