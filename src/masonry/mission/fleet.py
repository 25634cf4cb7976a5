"""The fleet a simulated mission flies: the blueprint's, or one of other sizes per role (``--brick-uavs``,
``--adhesion-uavs``), with homes for the UAVs it adds that pass the blueprint's validation. Pure.
"""

from __future__ import annotations

import dataclasses
import math

from masonry.blueprint import Blueprint, UavSpec, validate_blueprint
from masonry.errors import BlueprintError, InputError


def with_fleet(blueprint: Blueprint, fleet: tuple[UavSpec, ...]) -> Blueprint:
    """``blueprint`` flown by ``fleet`` (the sizes asked for): its added pads must pass validation too."""
    out = dataclasses.replace(blueprint, fleet=fleet)
    try:
        validate_blueprint(out)
    except BlueprintError as exc:
        raise InputError(
            f"the pads made for the UAVs added by `brick_uavs` / `adhesion_uavs` do not fit this site: {exc}; "
            "give the blueprint a fleet with their homes instead",
            options=("brick_uavs", "adhesion_uavs"),
        ) from exc
    return out


def fleet_for(
    blueprint: Blueprint, brick_uavs: int | None = None, adhesion_uavs: int | None = None
) -> tuple[UavSpec, ...]:
    """The blueprint's fleet, or one with ``brick_uavs`` / ``adhesion_uavs`` UAVs of each role.

    UAVs the blueprint names are kept (first ones of their role); extra ones are named ``brick-N`` /
    ``glue-N`` and parked in a row next to the last home of their role, ``2 * clearance`` apart, so
    that homes never violate the clearance.
    """
    out: list[UavSpec] = []
    taken = {u.name for u in blueprint.fleet}
    spacing = max(2.0, 2.0 * blueprint.clearance_m)
    for role, count, prefix in (("brick", brick_uavs, "brick"), ("adhesion", adhesion_uavs, "glue")):
        existing = list(blueprint.uavs(role))  # type: ignore[arg-type]
        if count is None:
            out.extend(existing)
            continue
        if count < 0:
            raise InputError(f"`{role}_uavs` must be >= 0, got {count}", options=(f"{role}_uavs",))
        kept = existing[:count]
        out.extend(kept)
        if len(kept) < count:
            homes = [u.home_m for u in blueprint.fleet] + [u.home_m for u in out]
            if kept:
                base = kept[-1].home_m
            else:
                base = _default_home(blueprint, role)
            k, n = 1, 0
            while len(kept) + n < count:
                name = f"{prefix}-{len(kept) + n + 1}"
                while name in taken:
                    name = f"{prefix}-{len(kept) + n + 1 + k * 100}"
                    k += 1
                home = (base[0] + spacing * (n + 1), base[1], base[2])
                while any(math.dist(home[:2], h[:2]) < spacing * 0.99 for h in homes):
                    home = (home[0] + spacing, home[1], home[2])
                homes.append(home)
                taken.add(name)
                out.append(UavSpec(name, role, home))  # type: ignore[arg-type]
                n += 1
    return tuple(out)


def _default_home(blueprint: Blueprint, role: str) -> tuple[float, float, float]:
    """A home row for a role the blueprint has no UAV of: in front of the wall (-y), left edge."""
    xs = [b.position_m[0] for b in blueprint.bricks] or [0.0]
    ys = [b.position_m[1] for b in blueprint.bricks] or [0.0]
    for b in blueprint.bricks:
        if b.pickup_m is not None:
            ys.append(b.pickup_m[1])
    offset = 3.0 * blueprint.clearance_m if role == "brick" else 5.0 * blueprint.clearance_m
    return (min(xs) - 2.0 * blueprint.clearance_m, min(ys) - offset, 0.0)


__all__ = ["fleet_for", "with_fleet"]
