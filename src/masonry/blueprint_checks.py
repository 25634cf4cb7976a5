"""The checks behind :func:`masonry.blueprint.validate_blueprint`: site ranges, marker ids, support, sites.

Pure: numbers in, :class:`~masonry.errors.BlueprintError` out, naming the file, the brick id or field, and the
problem. The limits are the named constants of :mod:`masonry.blueprint` (docs/blueprint-format.md, "Limits").
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from masonry.blueprint import (
    ARUCO_DICTIONARY_SIZES,
    MAX_ABS_YAW_RAD,
    MAX_BRICK_DIMENSION_M,
    MAX_BRICK_ID,
    MAX_CLEARANCE_M,
    MAX_HOME_HEIGHT_M,
    MAX_PICKUP_HEIGHT_M,
    MIN_BRICK_HEIGHT_M,
    MIN_SUPPORT_FRACTION,
    PENETRATION_TOL_M,
    RESTING_TOL_M,
    SITE_HALF_EXTENT_M,
    SITE_MAX_HEIGHT_M,
    Blueprint,
    Brick,
    MarkerSpec,
    _check_uav_name,
    _fmt,
    quote,
)
from masonry.errors import BlueprintError
from masonry.marker_reuse import check_marker_reuse
from masonry.planner.contacts import BrickArrays, find_contacts
from masonry.planner.overlap import clip_convex, polygon_area_centroid, rectangle_corners
from masonry.separation import PAD_MARGIN_M, pad_separation_m, pad_site_distance_m, zone_slack_m
from masonry.site_checks import check_site

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike

    from masonry.planner.contacts import Contacts


def validate(
    blueprint: Blueprint, contacts: Contacts | None = None, *, check_marker_ids: bool = True
) -> None:
    """The checks of :func:`masonry.blueprint.validate_blueprint` (see there), in the order they run."""

    source = blueprint.source
    bricks = blueprint.bricks
    markers = blueprint.markers
    _check_ranges(
        blueprint, check_marker_ids
    )  # first: the geometry below must not compute with absurd values
    for b in bricks:
        _check_brick_markers(b, markers, source)
        if not b.placed and b.pickup_m is None:
            raise BlueprintError(
                source, f"brick {b.id}", "`pickup` is required for a brick that is not placed"
            )
    if contacts is None:
        positions = [b.position_m for b in bricks]
        contacts = find_contacts(
            BrickArrays.of(positions, [b.size_m for b in bricks], [b.yaw_rad for b in bricks])
        )
    if len(contacts.penetrating):
        i, j = (int(k) for k in contacts.penetrating[0])
        raise BlueprintError(
            source,
            f"brick {bricks[i].id}",
            f"its volume interpenetrates brick {bricks[j].id} (more than "
            f"{_fmt(PENETRATION_TOL_M * 1000)} mm overlap)",
        )
    supported = {int(u) for u in contacts.upper}
    for index, b in enumerate(bricks):
        bottom = b.bottom_z_m
        if abs(bottom) <= RESTING_TOL_M or index in supported:
            continue
        if bottom < -RESTING_TOL_M:
            problem = f"its bottom is below the ground (z = {_fmt(bottom)} m)"
        else:
            problem = (
                f"neither on the ground nor resting on a brick below it (bottom at z = {_fmt(bottom)} m; "
                f"no brick top within {_fmt(RESTING_TOL_M * 1000)} mm under its footprint)"
            )
        raise BlueprintError(source, f"brick {b.id}", problem)
    has_adhesion = False
    for u, v in zip(contacts.upper.tolist(), contacts.lower.tolist()):
        upper, lower = bricks[u], bricks[v]
        if upper.placed and not lower.placed:
            raise BlueprintError(
                source, f"brick {upper.id}", f"is placed but rests on brick {lower.id}, which is not placed"
            )
        if not upper.placed:
            has_adhesion = True
    roles = {u.role for u in blueprint.fleet}
    if "brick" not in roles:
        raise BlueprintError(source, "fleet", "has no UAV with role `brick` to place the bricks")
    if has_adhesion and "adhesion" not in roles:
        raise BlueprintError(
            source, "fleet", "has no UAV with role `adhesion`, but the plan has adhesion tasks"
        )
    _check_support(bricks, contacts, source)
    _check_sites(blueprint)
    if blueprint.site is not None:
        check_site(blueprint)
    if check_marker_ids:
        check_marker_reuse(blueprint)


def _check_ranges(blueprint: Blueprint, check_marker_ids: bool = True) -> None:
    """Every number within the limits of a real site, every marker id in its dictionary, every UAV name a key."""
    source = blueprint.source
    c = blueprint.clearance_m
    if not 0.0 < c <= MAX_CLEARANCE_M:
        raise BlueprintError(source, "clearance", f"{_fmt(c)} m is outside (0, {_fmt(MAX_CLEARANCE_M)}] m")
    cruise = blueprint.cruise_altitude_m
    if not 0.0 < cruise <= SITE_MAX_HEIGHT_M:
        raise BlueprintError(
            source, "cruise_altitude", f"{_fmt(cruise)} m is outside (0, {_fmt(SITE_MAX_HEIGHT_M)}] m"
        )
    dictionary = blueprint.markers.dictionary
    capacity = ARUCO_DICTIONARY_SIZES.get(dictionary)
    if capacity is None:
        raise BlueprintError(
            source, "brick.markers.dictionary", f"unknown ArUco dictionary {quote(dictionary)}"
        )
    if not check_marker_ids:
        capacity = 2 * MAX_BRICK_ID + 2
    for b in _suspects(blueprint.bricks, capacity):
        where = f"brick {b.id}"
        id_ok = not isinstance(b.id, bool) and isinstance(b.id, int) and 0 <= b.id <= MAX_BRICK_ID
        if not id_ok and (not check_marker_ids or b.marker is not None):
            raise BlueprintError(source, f"brick {quote(b.id)}", f"id must be in 0..{MAX_BRICK_ID}")
        if b.marker is not None and (isinstance(b.marker, bool) or not isinstance(b.marker, int)):
            raise BlueprintError(
                source, f"{where}: marker", f"must be an integer >= 0, got {quote(b.marker)}"
            )
        if not id_ok or not 0 <= 2 * b.marker_number + 1 < capacity:
            _marker_out_of_range(b, dictionary, capacity, source)
        _check_point(b.position_m, SITE_MAX_HEIGHT_M, source, f"{where}: position")
        if not all(0.0 < v <= MAX_BRICK_DIMENSION_M for v in b.size_m):
            raise BlueprintError(
                source,
                f"{where}: size",
                f"every dimension must be in (0, {_fmt(MAX_BRICK_DIMENSION_M)}] m, "
                f"got {quote(list(b.size_m))}",
            )
        if not abs(b.yaw_rad) <= MAX_ABS_YAW_RAD:
            raise BlueprintError(
                source,
                f"{where}: yaw",
                f"|yaw| must be at most {_fmt(MAX_ABS_YAW_RAD)} rad (two turns), got {_fmt(b.yaw_rad)}",
            )
        if b.pickup_m is not None:
            _check_point(b.pickup_m, MAX_PICKUP_HEIGHT_M, source, f"{where}: pickup")
            bottom = b.pickup_m[2] - b.size_m[2] / 2.0
            if bottom < -RESTING_TOL_M:
                raise BlueprintError(
                    source,
                    f"{where}: pickup",
                    f"the brick would be below the ground there "
                    f"(its centre at z = {_fmt(b.pickup_m[2])} m, bottom at {_fmt(bottom)} m)",
                )
    _check_spares(blueprint, capacity)
    for u in blueprint.fleet:
        _check_uav_name(u.name, source, f"fleet UAV {quote(u.name)}: name")
        _check_point(u.home_m, MAX_HOME_HEIGHT_M, source, f"fleet UAV {quote(u.name)}: home")
        if u.home_m[2] < -RESTING_TOL_M:
            raise BlueprintError(
                source, f"fleet UAV {quote(u.name)}: home", f"z = {_fmt(u.home_m[2])} m is below the ground"
            )


def _check_spares(blueprint: Blueprint, capacity: int) -> None:
    """Each spare: an id no brick has, its markers in the dictionary and on its top face, a size and a pickup
    within the site's limits (its pickup's place among the others: :func:`_check_sites`)."""
    source, markers = blueprint.source, blueprint.markers
    brick_ids = {b.id for b in blueprint.bricks}
    for s in blueprint.spares or ():
        where = f"spare {s.id}"
        if s.id in brick_ids:
            raise BlueprintError(
                source, f"{where}: id", f"brick {s.id} has it too: a spare's id must be its own"
            )
        if not 2 * s.id + 1 < capacity:
            raise BlueprintError(
                source,
                f"{where}: id",
                f"its marker ids {2 * s.id}, {2 * s.id + 1} are not in {markers.dictionary} (marker ids "
                f"0..{capacity - 1})",
            )
        if not all(0.0 < v <= MAX_BRICK_DIMENSION_M for v in s.size_m):
            raise BlueprintError(
                source, f"{where}: size", f"every dimension must be in (0, {_fmt(MAX_BRICK_DIMENSION_M)}] m"
            )
        if markers.spacing_m + markers.size_m > s.size_m[0] + 1e-9 or markers.size_m > s.size_m[1] + 1e-9:
            raise BlueprintError(source, f"{where}: size", "its two markers do not fit on its top face")
        _check_point(s.pickup_m, MAX_PICKUP_HEIGHT_M, source, f"{where}: pickup")
        if s.pickup_m[2] - s.size_m[2] / 2.0 < -RESTING_TOL_M:
            raise BlueprintError(source, f"{where}: pickup", "the spare would be below the ground there")


def _who(b: Brick, blueprint: Blueprint) -> str:
    """``brick 7``, or ``spare 107`` for a spare's stand-in among the pickups."""
    spare = blueprint.spares is not None and any(s.id == b.id for s in blueprint.spares)
    return f"{'spare' if spare else 'brick'} {b.id}"


def _marker_out_of_range(b: Brick, dictionary: str, capacity: int, source: str) -> None:
    """A brick's marker ids beyond its dictionary: one line naming the brick and what to do."""
    if b.marker is not None:
        m = b.marker
        raise BlueprintError(
            source,
            f"brick {b.id}: marker",
            f"{m} (ArUco ids {2 * m}, {2 * m + 1}) is not in {dictionary} (marker numbers 0..{capacity // 2 - 1})",
        )
    largest = max(ARUCO_DICTIONARY_SIZES.values())
    hint = (
        "choose a larger dictionary"
        if capacity < largest
        else f"no ArUco dictionary holds more than {largest} markers ({largest // 2} bricks): give the bricks "
        "`marker` numbers reused where no camera sees two alike (`masonry blueprint` numbers big walls so)"
    )
    raise BlueprintError(
        source,
        f"brick {quote(b.id)}",
        f"its marker ids 2k, 2k+1 are not in {dictionary} (marker ids "
        f"0..{capacity - 1}: brick ids 0..{capacity // 2 - 1}); {hint}",
    )


def _suspects(bricks: tuple[Brick, ...], capacity: int) -> tuple[Brick, ...]:
    """The bricks from the first one that may break a range rule on (all checked one by one), found vectorised."""
    import numpy as np

    try:
        ids = np.array([b.id for b in bricks], dtype=np.int64)
        numbers = np.array([b.marker_number for b in bricks], dtype=np.int64)
    except (OverflowError, TypeError, ValueError):
        return bricks
    pos = np.array([b.position_m for b in bricks], dtype=float)
    size = np.array([b.size_m for b in bricks], dtype=float)
    yaw = np.array([b.yaw_rad for b in bricks], dtype=float)
    pick = np.array([b.pickup_m if b.pickup_m is not None else (0.0, 0.0, 1.0) for b in bricks], dtype=float)
    with np.errstate(invalid="ignore"):
        ok = (ids >= 0) & (ids <= MAX_BRICK_ID) & (numbers >= 0) & (2 * numbers + 1 < capacity)
        ok &= (np.abs(pos[:, :2]) <= SITE_HALF_EXTENT_M).all(axis=1) & (
            np.abs(pos[:, 2]) <= SITE_MAX_HEIGHT_M
        )
        ok &= ((size > 0.0) & (size <= MAX_BRICK_DIMENSION_M)).all(axis=1) & (np.abs(yaw) <= MAX_ABS_YAW_RAD)
        ok &= (np.abs(pick[:, :2]) <= SITE_HALF_EXTENT_M).all(axis=1) & (
            np.abs(pick[:, 2]) <= MAX_PICKUP_HEIGHT_M
        )
        ok &= pick[:, 2] - size[:, 2] / 2.0 >= -RESTING_TOL_M
    if ok.all():
        return ()
    return bricks[int(np.argmin(ok)) :]


def _check_point(p: tuple[float, float, float], max_z_m: float, source: str, where: str) -> None:
    x, y, z = p
    if not (abs(x) <= SITE_HALF_EXTENT_M and abs(y) <= SITE_HALF_EXTENT_M):
        raise BlueprintError(
            source,
            where,
            f"({_fmt(x)}, {_fmt(y)}) is off the site: |x| and |y| must be at most "
            f"{_fmt(SITE_HALF_EXTENT_M)} m",
        )
    if not abs(z) <= max_z_m:
        raise BlueprintError(source, where, f"z = {_fmt(z)} m is out of range: at most {_fmt(max_z_m)} m")


def _check_support(bricks: tuple[Brick, ...], contacts: Contacts, source: str) -> None:
    """A brick off the ground needs MIN_SUPPORT_FRACTION of its footprint on the bricks it rests on."""
    import numpy as np

    upper = np.asarray(contacts.upper, dtype=np.int64)
    lower = np.asarray(contacts.lower, dtype=np.int64)
    if len(upper) == 0:
        return
    center = np.array([b.position_m[:2] for b in bricks], dtype=float)
    half = np.array([b.size_m[:2] for b in bricks], dtype=float) / 2.0
    yaw = np.array([b.yaw_rad for b in bricks], dtype=float)
    # Axis-aligned footprints (yaw a multiple of pi/2, the usual case): rectangle overlap, vectorised.
    quarter = np.round(yaw / (math.pi / 2.0))
    aligned = np.abs(yaw - quarter * (math.pi / 2.0)) < 1e-9
    swap = (quarter.astype(np.int64) % 2) == 1
    ext = np.where(swap[:, None], half[:, ::-1], half)
    both = aligned[upper] & aligned[lower]
    lo = np.maximum(center[upper] - ext[upper], center[lower] - ext[lower])
    hi = np.minimum(center[upper] + ext[upper], center[lower] + ext[lower])
    area = np.where(both, np.prod(np.clip(hi - lo, 0.0, None), axis=1), 0.0)
    if not both.all():
        for k in np.nonzero(~both)[0].tolist():
            u, v = int(upper[k]), int(lower[k])
            a = rectangle_corners(tuple(center[u]), tuple(half[u]), float(yaw[u]))
            b = rectangle_corners(tuple(center[v]), tuple(half[v]), float(yaw[v]))
            poly = clip_convex(a, b)
            area[k] = polygon_area_centroid(poly)[0] if len(poly) >= 3 else 0.0
    supported = np.bincount(upper, weights=area, minlength=len(bricks))
    fraction = supported / (4.0 * half[:, 0] * half[:, 1])
    rests = np.zeros(len(bricks), dtype=bool)
    rests[upper] = True
    weak = np.nonzero(rests & (fraction < MIN_SUPPORT_FRACTION))[0]
    if len(weak):
        i = int(weak[0])
        under = sorted(bricks[int(v)].id for v in lower[upper == i])
        raise BlueprintError(
            source,
            f"brick {bricks[i].id}",
            f"only {fraction[i] * 100:.1f} % of its footprint rests on brick(s) {', '.join(map(str, under))} "
            f"(at least {MIN_SUPPORT_FRACTION * 100:.0f} % must)",
        )


def _check_sites(blueprint: Blueprint) -> None:
    """Cruise above the wall; pickups and homes off the wall's footprint; no shared pickup; pads apart and clear
    of the work (``masonry.separation``)."""
    import numpy as np

    source = blueprint.source
    bricks = blueprint.bricks
    top = max(bricks, key=lambda b: b.top_z_m)
    if not blueprint.cruise_altitude_m > top.top_z_m:
        raise BlueprintError(
            source,
            "cruise_altitude",
            f"{_fmt(blueprint.cruise_altitude_m)} m is not above the finished wall's top "
            f"(z = {_fmt(top.top_z_m)} m, brick {top.id}): the UAVs would cruise through the wall",
        )
    from scipy.spatial import cKDTree

    center = np.array([b.position_m[:2] for b in bricks], dtype=float)
    footprints = (
        center,
        np.array([b.size_m[:2] for b in bricks], dtype=float) / 2.0,
        np.array([b.yaw_rad for b in bricks], dtype=float),
        cKDTree(center),
    )
    todo = [b for b in bricks if b.pickup_m is not None and not b.placed]
    # a spare waits at its pickup as a brick does (docs/blueprint-format.md, "Spares")
    todo += [Brick(s.id, s.pickup_m, s.size_m, pickup_m=s.pickup_m) for s in blueprint.spares or ()]
    pickups = np.array([b.pickup_m for b in todo], dtype=float).reshape(-1, 3)
    hit = _inside_footprints(pickups[:, :2], footprints)
    if hit is not None:
        k, j = hit
        raise BlueprintError(
            source,
            f"{_who(todo[k], blueprint)}: pickup",
            f"lies inside the wall's footprint (under brick {bricks[j].id})",
        )
    # Two bricks whose pickup centres are closer than the smaller one's smallest side would interpenetrate there.
    room = np.array([min(b.size_m) for b in todo], dtype=float) - 2.0 * PENETRATION_TOL_M
    pair = _close_pair(pickups, room)
    if pair is not None:
        a, b = sorted(pair, key=lambda k: todo[k].id)
        raise BlueprintError(
            source,
            f"{_who(todo[b], blueprint)}: pickup",
            f"is {_who(todo[a], blueprint)}'s pickup too: the two would "
            f"overlap there ({_fmt(float(np.linalg.norm(pickups[a] - pickups[b])))} m apart)",
        )
    _check_pads(blueprint, footprints, pickups, todo)


def _check_pads(
    blueprint: Blueprint,
    footprints: tuple[np.ndarray, np.ndarray, np.ndarray, Any],
    pickups: np.ndarray,
    todo: list[Brick],
) -> None:
    """Pads (homes) off the wall, far enough apart for two airframes, and far enough from the wall and every
    pickup that a landed UAV never blocks the work there: what validates can be flown (docs/safety.md)."""
    import numpy as np

    source, bricks, fleet = blueprint.source, blueprint.bricks, blueprint.fleet
    homes = np.array([u.home_m for u in fleet], dtype=float).reshape(-1, 3)
    hit = _inside_footprints(homes[:, :2], footprints)
    if hit is not None:
        k, j = hit
        raise BlueprintError(
            source,
            f"fleet UAV {quote(fleet[k].name)}: home",
            f"lies inside the wall's footprint (under brick {bricks[j].id})",
        )
    flat = homes.copy()
    flat[:, 2] = 0.0
    apart_m = pad_separation_m()
    pair = _close_pair(flat, np.full(len(fleet), apart_m - 1e-9))
    if pair is not None:
        a, b = sorted(pair)
        gap = float(np.linalg.norm(flat[a] - flat[b]))
        raise BlueprintError(
            source,
            f"fleet UAV {quote(fleet[b].name)}: home",
            f"is {_fmt(round(gap, 3))} m from the home of {quote(fleet[a].name)}: pads must be at least "
            f"{_fmt(apart_m)} m apart (the airframe's {_fmt(apart_m - PAD_MARGIN_M)} m span plus "
            f"{_fmt(PAD_MARGIN_M)} m)",
        )
    clear_m = pad_site_distance_m(blueprint.clearance_m)
    why = (
        f"a pad must be at least {_fmt(round(clear_m, 3))} m from the wall and from every pickup "
        f"({_fmt(apart_m)} m from a landed UAV plus the {_fmt(round(zone_slack_m(blueprint.clearance_m), 3))} m "
        "a UAV working there may drift), or a UAV on it blocks the work"
    )
    near = _inside_footprints(homes[:, :2], footprints, margin_m=clear_m)
    if near is not None:
        k, j = near
        raise BlueprintError(
            source,
            f"fleet UAV {quote(fleet[k].name)}: home",
            f"is {_fmt(round(_footprint_distance_m(homes[k, :2], footprints, j), 3))} m from the wall "
            f"(brick {bricks[j].id}): {why}",
        )
    if len(todo):
        from scipy.spatial import cKDTree

        d, i = cKDTree(pickups[:, :2]).query(homes[:, :2])
        for k in np.argsort(d, kind="stable")[:1]:
            if d[k] < clear_m - 1e-9:
                raise BlueprintError(
                    source,
                    f"fleet UAV {quote(fleet[k].name)}: home",
                    f"is {_fmt(round(float(d[k]), 3))} m from {_who(todo[int(i[k])], blueprint)}'s pickup: {why}",
                )


def _footprint_distance_m(
    point_xy: ArrayLike, footprints: tuple[np.ndarray, np.ndarray, np.ndarray, Any], j: int
) -> float:
    """Horizontal distance from ``point_xy`` to brick ``j``'s footprint (0 inside)."""
    import numpy as np

    center, half, yaw, _tree = footprints
    d = np.asarray(point_xy, dtype=float) - center[j]
    c, s = math.cos(float(yaw[j])), math.sin(float(yaw[j]))
    u, v = abs(c * d[0] + s * d[1]), abs(-s * d[0] + c * d[1])
    return math.hypot(max(0.0, u - float(half[j, 0])), max(0.0, v - float(half[j, 1])))


def _inside_footprints(
    points_xy: ArrayLike, footprints: tuple[np.ndarray, np.ndarray, np.ndarray, Any], margin_m: float = 0.0
) -> tuple[int, int] | None:
    """(point index, brick index) of the first point strictly inside a brick's footprint (or, with
    ``margin_m``, closer to it than that), if any.

    ``footprints``: the bricks' (n, 2) centres, (n, 2) half sizes, (n,) yaws, and a KD-tree of the centres.
    """
    import numpy as np

    points_xy = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    if len(points_xy) == 0:
        return None
    center, half, yaw, tree = footprints
    radius = float(np.hypot(half[:, 0], half[:, 1]).max()) + margin_m
    near = tree.query_ball_point(points_xy, r=radius)
    counts = np.array([len(n) for n in near], dtype=np.int64)
    if counts.sum() == 0:
        return None
    point = np.repeat(np.arange(len(points_xy)), counts)
    brick = np.concatenate([np.asarray(n, dtype=np.int64) for n in near if n])
    d = points_xy[point] - center[brick]
    c, s = np.cos(yaw[brick]), np.sin(yaw[brick])
    u = c * d[:, 0] + s * d[:, 1]
    v = -s * d[:, 0] + c * d[:, 1]
    if margin_m > 0.0:
        gap = np.hypot(
            np.maximum(np.abs(u) - half[brick, 0], 0.0), np.maximum(np.abs(v) - half[brick, 1], 0.0)
        )
        inside = gap < margin_m - 1e-9
    else:
        inside = (np.abs(u) < half[brick, 0] - 1e-9) & (np.abs(v) < half[brick, 1] - 1e-9)
    hits = sorted(zip(point[inside].tolist(), brick[inside].tolist()))
    return hits[0] if hits else None


def _close_pair(points: ArrayLike, room: np.ndarray) -> tuple[int, int] | None:
    """The first pair (i, j), i < j, of points closer than min(room[i], room[j]), if any."""
    import numpy as np
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(points) < 2 or float(room.max()) <= 0.0:
        return None
    pairs = cKDTree(points).query_pairs(r=float(room.max()), output_type="ndarray")
    if len(pairs) == 0:
        return None
    a, b = pairs[:, 0], pairs[:, 1]
    close = np.linalg.norm(points[a] - points[b], axis=1) < np.minimum(room[a], room[b])
    found = sorted(zip(np.minimum(a, b)[close].tolist(), np.maximum(a, b)[close].tolist()))
    return found[0] if found else None


#: Same values as masonry.planner.contacts (kept here so the messages need no planner import).
def _check_brick_markers(b: Brick, markers: MarkerSpec, source: str) -> None:
    length, width, height = b.size_m
    if height <= 2 * RESTING_TOL_M:
        raise BlueprintError(
            source, f"brick {b.id}: size", f"height {_fmt(height)} m must exceed {_fmt(MIN_BRICK_HEIGHT_M)} m"
        )
    if markers.spacing_m + markers.size_m > length + 1e-9 or markers.size_m > width + 1e-9:
        raise BlueprintError(
            source,
            f"brick {b.id}: size",
            f"the two {_fmt(markers.size_m)} m markers {_fmt(markers.spacing_m)} m apart do not fit on its "
            f"{_fmt(length)} x {_fmt(width)} m top face",
        )
