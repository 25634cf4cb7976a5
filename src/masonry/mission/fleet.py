"""The fleet a simulated mission flies: the blueprint's, or one of other sizes per role (``--brick-uavs``,
``--adhesion-uavs``), with homes for the UAVs it adds that pass the blueprint's validation. Pure.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from masonry.blueprint import Blueprint, UavSpec, validate_blueprint
from masonry.errors import BlueprintError, InputError
from masonry.mission.sites import work_point_m
from masonry.planner.dispatch_admission import Admission, site_width
from masonry.planner.graphs import plan as make_plan


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


#: A fleet's *core*: at most this many brick UAVs per sprayer, and one sprayer per this many brick UAVs (rounded
#: up), the ratio of the default fleets (4 + 2, 6 + 3, 8 + 4). The UAVs of a role past its core are *spares*: laid
#: on pads past the core's, kept on them by the dispatcher until a UAV of the core goes home for its battery
#: (docs/dispatch.md, "Spares past the 2 : 1 core"; the 12 m wall at 6 + 2, 8 + 2, 4 + 4 was slower than 4 + 2).
BRICK_UAVS_PER_SPRAYER = 2


def core_counts(brick_uavs: int, adhesion_uavs: int) -> tuple[int, int]:
    """The (brick, adhesion) UAVs of a fleet's core (:data:`BRICK_UAVS_PER_SPRAYER`); a fleet with no UAV of a
    role is all core."""
    if brick_uavs < 1 or adhesion_uavs < 1:
        return brick_uavs, adhesion_uavs
    per = BRICK_UAVS_PER_SPRAYER
    return min(brick_uavs, per * adhesion_uavs), min(adhesion_uavs, -(-brick_uavs // per))


def core_of_role(role: str, live: Mapping[str, int]) -> int:
    """How many UAVs of ``role`` the core of a fleet of ``live`` UAVs per role has (:func:`core_counts`)."""
    bricks, sprayers = core_counts(live.get("brick", 0), live.get("adhesion", 0))
    return bricks if role == "brick" else sprayers


def spares_rest(role: str, left_s: Mapping[str, float], live: Mapping[str, int]) -> bool:
    """``role`` has spares past the fleet's core and its core would finish its work left before the other role's
    core finishes theirs: the spares stay on their pads, through the core's battery swaps too, and the role flies as
    its core (docs/dispatch.md, "Spares past the 2 : 1 core").

    Args:
        role: ``brick`` or ``adhesion``.
        left_s: each role's expected seconds of tasks not done (:func:`masonry.planner.estimate_durations_s`).
        live: each role's UAVs in the mission.

    A spare of a role that is not the wall's pace lays nothing sooner: the wall waits on the other role. Flown in a
    swapping UAV's place it only reorders the work and crosses the other role's legs (the 12 m wall's 4 + 4, seeds
    1-3: +7 to +11 s over 4 + 2, the sprayers done 26-95 s sooner, the bricks later).
    """
    other = "adhesion" if role == "brick" else "brick"
    core, core_other = core_of_role(role, live), core_of_role(other, live)
    if live.get(role, 0) <= core or core_other < 1:
        return False
    return left_s.get(role, 0.0) / core < left_s.get(other, 0.0) / core_other


def fleet_for(
    blueprint: Blueprint,
    brick_uavs: int | None = None,
    adhesion_uavs: int | None = None,
    *,
    admission: bool = True,
) -> tuple[UavSpec, ...]:
    """The blueprint's fleet, or one with ``brick_uavs`` / ``adhesion_uavs`` UAVs of each role.

    UAVs the blueprint names are kept (first ones of their role); extra ones are named ``brick-N`` /
    ``glue-N`` and parked in a row next to the last home of their role, ``2 * clearance`` apart, so
    that homes never violate the clearance. With both sizes given, the fleet's core (:func:`core_counts`) is laid
    first, and its spares after it, each past the last pad of its role and clear of every pad before: adding
    spares moves no pad of the core (the 12 m wall's 8 + 2 keeps 4 + 2's pads). On a wall that narrows the core
    (:func:`narrowed`: the admission rule keeps it to fewer busy UAVs) the core is laid step by step up its
    :func:`ladder` (2 + 1, then 4 + 2's added UAVs past those, ...), so it keeps every smaller step's pads: the
    pyramid's 8 + 4 keeps 4 + 2's glue-2 at 14 m, where laid in one go it stood past all eight brick pads, at 26 m
    (issue 27 §4, branch ``more42``). Elsewhere the core is laid in one go, and so everywhere with ``admission``
    False: a mission with no separation (no admission rule), or under ``--airspace table`` (the rule holds there
    since ``table44``, but the pyramid's 6 + 3, seed 1, laid up the ladder did not complete before it).
    """
    if brick_uavs is None or adhesion_uavs is None or brick_uavs < 0 or adhesion_uavs < 0:
        return _laid(blueprint, {"brick": brick_uavs, "adhesion": adhesion_uavs}, ())
    core_b, core_a = core_counts(brick_uavs, adhesion_uavs)
    steps = ladder(core_b, core_a)
    if len(steps) > 2 and not (admission and narrowed(blueprint, core_b + core_a)):
        steps = steps[-1:]  # (laid in one go: up the ladder, the 12 m wall's 8 + 4 was +147 s on seed 1)
    core: tuple[UavSpec, ...] = ()
    for step_b, step_a in steps:
        core = _laid(blueprint, {"brick": step_b, "adhesion": step_a}, core)
    if (core_b, core_a) == (brick_uavs, adhesion_uavs):
        return core
    return _laid(blueprint, {"brick": brick_uavs, "adhesion": adhesion_uavs}, core)


def ladder(brick_uavs: int, adhesion_uavs: int) -> list[tuple[int, int]]:
    """The fleets a core of ``brick_uavs`` + ``adhesion_uavs`` is laid out through, smallest first: a step of
    :data:`BRICK_UAVS_PER_SPRAYER` brick UAVs and one sprayer at a time (4 + 2 through 2 + 1 and 4 + 2; 8 + 4
    through 2 + 1, 4 + 2, 6 + 3 and 8 + 4), each step's pads laid past the one's before, so a fleet's pads hold
    every smaller step's (used where the wall narrows the fleet: :func:`narrowed`)."""
    per = BRICK_UAVS_PER_SPRAYER
    steps = max(1, -(-brick_uavs // per), adhesion_uavs)
    out = [(min(brick_uavs, per * k), min(adhesion_uavs, k)) for k in range(1, steps + 1)]
    return out if out[-1] == (brick_uavs, adhesion_uavs) else [*out, (brick_uavs, adhesion_uavs)]


def narrowed(blueprint: Blueprint, uavs: int) -> bool:
    """The admission rule (:class:`masonry.planner.dispatch_admission.Admission`) keeps a fleet of ``uavs`` on
    ``blueprint``'s wall to fewer busy UAVs from the start: more than :data:`~masonry.planner.dispatch_admission.
    UAVS_PER_SITE` per site the wall can work at once, r_c apart (the bundled pyramid from 4 + 2 up; neither running
    bond of the fleet benchmarks up to 8 + 4)."""
    points = [work_point_m(t)[:2] for t in make_plan(blueprint, check_marker_ids=False).tasks if not t.done]
    width = site_width(((p[0], p[1]) for p in points), blueprint.clearance_m)
    return Admission(width, landed=lambda _name: True).applies(uavs)


def _laid(
    blueprint: Blueprint, counts: dict[str, int | None], core: tuple[UavSpec, ...]
) -> tuple[UavSpec, ...]:
    """:func:`fleet_for`'s rows: the blueprint's UAVs, then ``core``'s added ones, then new ones past both."""
    out: list[UavSpec] = []
    own = {u.name for u in blueprint.fleet}
    taken = own | {u.name for u in core}
    spacing = max(2.0, 2.0 * blueprint.clearance_m)
    for role, prefix in (("brick", "brick"), ("adhesion", "glue")):
        count = counts[role]
        existing = list(blueprint.uavs(role))  # type: ignore[arg-type]
        if count is None:
            out.extend(existing)
            continue
        if count < 0:
            raise InputError(f"`{role}_uavs` must be >= 0, got {count}", options=(f"{role}_uavs",))
        added = [u for u in core if u.role == role and u.name not in own]
        kept = existing[:count] + added[: max(0, count - len(existing))]
        out.extend(kept)
        if len(kept) < count:
            homes = [u.home_m for u in blueprint.fleet] + [u.home_m for u in core] + [u.home_m for u in out]
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


__all__ = [
    "BRICK_UAVS_PER_SPRAYER",
    "core_counts",
    "core_of_role",
    "fleet_for",
    "ladder",
    "narrowed",
    "spares_rest",
    "with_fleet",
]
