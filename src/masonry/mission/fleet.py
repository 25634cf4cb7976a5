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
    ``glue-N`` and parked on the row of the blueprint's pads, ``2 * clearance`` apart so that homes never
    violate the clearance, on the free spots of that row nearest the middle of the wall (:func:`_centred_homes`;
    the roles interleaved): a pad far down the row is a long flight to the wall at take-off and at every battery
    swap. Where those pads do not pass the blueprint's validation, they trail the last home of their role instead.
    """
    kept: dict[str, list[UavSpec]] = {}
    wanted: dict[str, int] = {}
    for role, count in (("brick", brick_uavs), ("adhesion", adhesion_uavs)):
        existing = list(blueprint.uavs(role))  # type: ignore[arg-type]
        if count is not None and count < 0:
            raise InputError(f"`{role}_uavs` must be >= 0, got {count}", options=(f"{role}_uavs",))
        kept[role] = existing if count is None else existing[:count]
        wanted[role] = len(kept[role]) if count is None else count
    if all(len(kept[r]) == wanted[r] for r in kept):
        return tuple(kept["brick"]) + tuple(kept["adhesion"])
    centred = _centred_homes(blueprint, kept, wanted)
    if centred is not None:
        return centred
    return _trailing_homes(blueprint, kept, wanted)


def _new_names(blueprint: Blueprint, kept: dict[str, list[UavSpec]], wanted: dict[str, int]) -> dict[str, list[str]]:
    """The names of the UAVs added per role: ``brick-N`` / ``glue-N`` after the kept ones, none already taken."""
    taken = {u.name for u in blueprint.fleet}
    out: dict[str, list[str]] = {}
    for role, prefix in (("brick", "brick"), ("adhesion", "glue")):
        names: list[str] = []
        k = 1
        for n in range(wanted[role] - len(kept[role])):
            name = f"{prefix}-{len(kept[role]) + n + 1}"
            while name in taken:
                name = f"{prefix}-{len(kept[role]) + n + 1 + k * 100}"
                k += 1
            taken.add(name)
            names.append(name)
        out[role] = names
    return out


def _centred_homes(
    blueprint: Blueprint, kept: dict[str, list[UavSpec]], wanted: dict[str, int]
) -> tuple[UavSpec, ...] | None:
    """The fleet with its added pads on the pad row's free spots nearest the wall's middle (along x), the roles
    taking turns (the role with the smallest share of its added UAVs placed goes next); None where the blueprint
    has no pad to line them up with, or the pads fail its validation."""
    anchors = [u.home_m for r in ("brick", "adhesion") for u in kept[r]]
    if not anchors:
        return None
    spacing = max(2.0, 2.0 * blueprint.clearance_m)
    xs = [b.position_m[0] for b in blueprint.bricks] or [0.0]
    middle_x = (min(xs) + max(xs)) / 2.0
    base = anchors[0]
    homes = [u.home_m for u in blueprint.fleet] + anchors
    names = _new_names(blueprint, kept, wanted)
    added: dict[str, list[UavSpec]] = {"brick": [], "adhesion": []}
    reach = sum(len(v) for v in names.values()) + len(homes) + 1
    spots = sorted(
        ((base[0] + spacing * j, base[1], base[2]) for j in range(-2 * reach, 2 * reach + 1)),
        key=lambda h: (abs(h[0] - middle_x), h[0]),
    )
    while any(len(added[r]) < len(names[r]) for r in names):
        role = min(
            (r for r in names if len(added[r]) < len(names[r])), key=lambda r: (len(added[r]) / len(names[r]), r)
        )
        home = next(h for h in spots if all(math.dist(h[:2], o[:2]) >= spacing * 0.99 for o in homes))
        homes.append(home)
        added[role].append(UavSpec(names[role][len(added[role])], role, home))  # type: ignore[arg-type]
    fleet = tuple(kept["brick"] + added["brick"] + kept["adhesion"] + added["adhesion"])
    try:
        validate_blueprint(dataclasses.replace(blueprint, fleet=fleet))
    except BlueprintError:
        return None
    return fleet


def _trailing_homes(
    blueprint: Blueprint, kept: dict[str, list[UavSpec]], wanted: dict[str, int]
) -> tuple[UavSpec, ...]:
    """The fleet with its added pads in a row after the last home of their role (the layout before the centred
    one; :func:`_default_home` for a role the blueprint has no UAV of)."""
    out: list[UavSpec] = []
    spacing = max(2.0, 2.0 * blueprint.clearance_m)
    names = _new_names(blueprint, kept, wanted)
    for role in ("brick", "adhesion"):
        out.extend(kept[role])
        homes = [u.home_m for u in blueprint.fleet] + [u.home_m for u in out]
        base = kept[role][-1].home_m if kept[role] else _default_home(blueprint, role)
        for n, name in enumerate(names[role]):
            home = (base[0] + spacing * (n + 1), base[1], base[2])
            while any(math.dist(home[:2], h[:2]) < spacing * 0.99 for h in homes):
                home = (home[0] + spacing, home[1], home[2])
            homes.append(home)
            out.append(UavSpec(name, role, home))  # type: ignore[arg-type]
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
