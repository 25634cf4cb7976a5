"""The blueprint's ``site`` (its geofence, :class:`masonry.geofence.Site`): parsing and validation.

Pure: YAML values in, a :class:`~masonry.geofence.Site` or a :class:`~masonry.errors.BlueprintError` out, one
line naming the file, the field (``site.boundary``, ``site.max_altitude``, a brick, a pickup, a home) and the
problem (docs/blueprint-format.md, "Site").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from masonry.blueprint import (
    SITE_HALF_EXTENT_M,
    Blueprint,
    _check_keys,
    _fmt,
    _kind,
    _number,
    quote,
)
from masonry.errors import BlueprintError
from masonry.geofence import (
    ALTITUDE_MARGIN_M,
    MAX_BOUNDARY_VERTICES,
    SITE_MARGIN_M,
    Site,
    simple_polygon_problem,
)
from masonry.separation import LAYER_SPACING_M
from masonry.timing import DEFAULT_TIMING

SITE_KEYS = ("boundary", "max_altitude")
#: ``max_altitude`` at most this (metres): beyond it is a typing mistake (the site limits' horizontal extent).
MAX_SITE_ALTITUDE_M = SITE_HALF_EXTENT_M


def parse_site(raw: Any, source: str) -> Site | None:
    """The ``site`` mapping of a blueprint file (None: absent), checked on its own (a simple polygon, finite
    numbers within the site limits, a positive altitude limit).

    Raises:
        BlueprintError: one line naming ``source`` and the field.
    """
    if raw is None:
        return None
    if not isinstance(raw, Mapping):
        raise BlueprintError(
            source, "site", f"must be a mapping with `boundary` and `max_altitude`, got {_kind(raw)}"
        )
    _check_keys(raw, SITE_KEYS, SITE_KEYS, source, "site")
    boundary = raw["boundary"]
    where = "site.boundary"
    if not isinstance(boundary, list):
        raise BlueprintError(
            source, where, f"must be a list of [x, y] points in metres, got {_kind(boundary)}"
        )
    if len(boundary) > MAX_BOUNDARY_VERTICES:
        raise BlueprintError(source, where, f"has {len(boundary)} vertices: at most {MAX_BOUNDARY_VERTICES}")
    points: list[tuple[float, float]] = []
    for i, p in enumerate(boundary):
        if not isinstance(p, (list, tuple)) or len(p) != 2:
            raise BlueprintError(source, f"{where}[{i}]", f"must be a point [x, y] in metres, got {quote(p)}")
        x, y = (_number(v, source, f"{where}[{i}]") for v in p)
        if abs(x) > SITE_HALF_EXTENT_M or abs(y) > SITE_HALF_EXTENT_M:
            raise BlueprintError(
                source,
                f"{where}[{i}]",
                f"({_fmt(x)}, {_fmt(y)}) is out of range: |x| and |y| at most {_fmt(SITE_HALF_EXTENT_M)} m",
            )
        points.append((x, y))
    problem = simple_polygon_problem(points)
    if problem is not None:
        raise BlueprintError(source, where, problem)
    altitude = _number(raw["max_altitude"], source, "site.max_altitude")
    if not 0.0 < altitude <= MAX_SITE_ALTITUDE_M:
        raise BlueprintError(
            source, "site.max_altitude", f"{_fmt(altitude)} m is outside (0, {_fmt(MAX_SITE_ALTITUDE_M)}] m"
        )
    return Site(tuple(points), altitude)


def highest_transit_layer_m(blueprint: Blueprint) -> float:
    """The highest transit layer the airspace uses for ``blueprint`` (the default timing): the fixed fallback
    layer of the last UAV of its fleet, ``work altitude + len(fleet) * spacing``
    (:func:`masonry.mission.altitudes.transit_layers_m`; mission control's layers stay under the fence)."""
    t = DEFAULT_TIMING
    z = float(blueprint.cruise_altitude_m)
    for b in blueprint.bricks:
        top, size_z = b.top_z_m, float(b.size_m[2])
        z = max(z, t.spray_altitude_m(top), t.carry_altitude_m(top, size_z))
    return z + len(blueprint.fleet) * LAYER_SPACING_M


def check_site(blueprint: Blueprint) -> None:
    """The wall, every pickup and every home at least ``SITE_MARGIN_M`` inside the site's boundary, and the
    altitude limit ``ALTITUDE_MARGIN_M`` above the highest transit layer.

    Raises:
        BlueprintError: naming the brick, pickup, home or ``site.max_altitude``, how far inside it is and the
            minimum.
    """
    site = blueprint.site
    if site is None:
        return
    source = blueprint.source
    need = SITE_MARGIN_M

    def check(x: float, y: float, where: str, what: str) -> None:
        d = site.inside_m(x, y)
        if d >= need:
            return
        if d < 0.0:
            problem = f"{what} ({_fmt(x)}, {_fmt(y)}) lies {_fmt(-d)} m outside the site boundary"
        else:
            problem = f"{what} ({_fmt(x)}, {_fmt(y)}) lies only {_fmt(d)} m inside the site boundary"
        raise BlueprintError(source, where, f"{problem} (at least {_fmt(need)} m inside: `site`)")

    for b in blueprint.bricks:
        for cx, cy in b.footprint_m():
            check(cx, cy, f"brick {b.id}", "a corner of its footprint")
    for b in blueprint.bricks:
        if b.pickup_m is not None and not b.placed:
            check(b.pickup_m[0], b.pickup_m[1], f"brick {b.id}: pickup", "the pickup")
    for u in blueprint.fleet:
        check(u.home_m[0], u.home_m[1], f"fleet UAV {quote(u.name)}: home", "the home pad")
    top = highest_transit_layer_m(blueprint)
    if not site.max_altitude_m >= top + ALTITUDE_MARGIN_M - 1e-9:
        raise BlueprintError(
            source,
            "site.max_altitude",
            f"{_fmt(site.max_altitude_m)} m is not {_fmt(ALTITUDE_MARGIN_M)} m above the highest transit layer "
            f"({_fmt(round(top, 3))} m: layer 0 over the finished wall plus {len(blueprint.fleet)} x "
            f"{_fmt(LAYER_SPACING_M)} m for a fleet of {len(blueprint.fleet)}): at least "
            f"{_fmt(round(top + ALTITUDE_MARGIN_M, 3))} m",
        )


def format_site(site: Site) -> str:
    """The ``site:`` line of a blueprint file (flow style)."""
    from masonry.blueprint import _num

    points = ", ".join(f"[{_num(x)}, {_num(y)}]" for x, y in site.boundary_m)
    return f"site: {{boundary: [{points}], max_altitude: {_num(site.max_altitude_m)}}}"


__all__ = [
    "MAX_SITE_ALTITUDE_M",
    "SITE_KEYS",
    "check_site",
    "format_site",
    "highest_transit_layer_m",
    "parse_site",
]
