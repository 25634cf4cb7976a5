"""Generated blueprints: running-bond walls, towers and pyramids of any size (pure; returns Blueprint values).

Every generator lays the wall in its own frame (u along the wall, v across it, z up), then rotates it by
``yaw_rad`` about z and moves it to ``origin_m``. Bricks of the lowest ``placed_courses`` courses are placed
already; every other brick gets a pickup point on a pallet: a grid on the ground on the -v side of the wall,
``pallet_distance_m`` (default r_c + 1 m) away from it. Along a long wall (>= 4.5 m) the pallet is as wide as the
wall and each brick lies on the free slot nearest to its place, every other brick of a course 3 rows behind
(short carries; bricks side by side on the wall are picked up rows apart, bricks placed together, r_c apart,
about as far apart); a shorter wall's pallet is 10 slots wide (wider than the wall, so the
bricks fetched together are spread across it), filled row by row; so is one of ``pallet_columns`` columns. UAV homes are in a row beyond the pallet, r_c + 0.5 m
apart (at least ``masonry.separation.pad_separation_m``, 1 m).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from masonry.blueprint import (
    DEFAULT_BRICK_SIZE_M,
    DEFAULT_CLEARANCE_M,
    DEFAULT_CRUISE_ALTITUDE_M,
    Blueprint,
    Brick,
    MarkerSpec,
    Role,
    UavSpec,
)
from masonry.errors import BlueprintError
from masonry.marker_reuse import assign_markers, marker_capacity
from masonry.separation import pad_separation_m
from masonry.spares import Spare

Vec3 = tuple[float, float, float]
#: (u, v, course) of each brick in the wall frame, plus its yaw relative to the wall.
_Layout = list[tuple[float, float, int, float]]

GENERATORS: tuple[str, ...] = ("running-bond", "towers", "pyramid")
#: A wall at least this many pallet columns long (0.5 m each: 4.5 m with the default brick) gets a pallet as wide
#: as itself, each brick facing its place; a shorter one the old 10-column pallet filled row by row.
PALLET_MIN_COLUMNS = 10
#: On a long wall's pallet, every other brick of a course lies this many rows (0.45 m each) behind its neighbours,
#: so that two bricks side by side on the wall are not picked up side by side (docs/performance/fleet.md).
PALLET_ROW_STRIDE = 3
#: A wall taller than the default cruise altitude is cruised over this much above its top (unless one is given).
CRUISE_OVER_WALL_M = 0.5


@dataclass(frozen=True)
class Site:
    """Where and how a generated wall is laid out, and the fleet that builds it (every generator's options)."""

    brick_size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M
    yaw_rad: float = 0.0
    origin_m: tuple[float, ...] = (0.0, 0.0)
    placed_courses: int = 0
    brick_uavs: int = 1
    adhesion_uavs: int = 1
    clearance_m: float = DEFAULT_CLEARANCE_M
    cruise_altitude_m: float | None = (
        None  # None: DEFAULT_CRUISE_ALTITUDE_M, or CRUISE_OVER_WALL_M over a taller wall
    )
    pallet_columns: int = 0  # 0: as wide as a long wall, else 10 (20 beyond 40 bricks); given: row by row
    pallet_distance_m: float | None = None  # from the wall's face to the pallet; default r_c + 1 m
    name: str | None = None
    markers: MarkerSpec | None = None  # default: fitted to the brick, dictionary numbering every brick
    spares: int | None = (
        None  # spare bricks after the wall's on the pallet (ids after the bricks'); None: no key
    )


def running_bond(
    courses: int = 4, bricks_per_course: int = 6, *, joint_m: float = 0.0, **site: Any
) -> Blueprint:
    """A straight wall of stretchers; every other course is shifted by half a brick (running bond).

    ``joint_m`` is the gap between neighbours in a course; ``site`` takes the fields of :class:`Site`.
    """
    options = Site(**site)
    _check_count("courses", courses)
    _check_count("bricks per course", bricks_per_course)
    length, _, _ = _size(options)
    pitch = length + joint_m
    layout: _Layout = []
    for course in range(courses):
        shift = pitch / 2.0 if course % 2 else 0.0
        for k in range(bricks_per_course):
            layout.append((k * pitch + shift, 0.0, course, 0.0))
    return _build("running-bond", layout, options)


def towers(towers: int = 2, height: int = 3, spacing_m: float = 1.0, **site: Any) -> Blueprint:
    """``towers`` stacks of ``height`` bricks each, ``spacing_m`` apart along the wall line."""
    options = Site(**site)
    _check_count("towers", towers)
    _check_count("height", height)
    length, _, _ = _size(options)
    if not (math.isfinite(spacing_m) and spacing_m > 0.0):
        raise BlueprintError("<generator>", "spacing", f"must be > 0, got {spacing_m}")
    if towers > 1 and spacing_m < length:
        raise BlueprintError(
            "<generator>", "spacing", f"{spacing_m} m is less than the brick length {length} m"
        )
    layout: _Layout = [(t * spacing_m, 0.0, course, 0.0) for t in range(towers) for course in range(height)]
    return _build("towers", layout, options)


def pyramid(base: int = 5, *, joint_m: float = 0.0, **site: Any) -> Blueprint:
    """A stepped pyramid wall: ``base`` bricks in the first course, one fewer in each course above."""
    options = Site(**site)
    _check_count("base", base)
    length, _, _ = _size(options)
    pitch = length + joint_m
    layout: _Layout = []
    for course in range(base):
        for k in range(base - course):
            layout.append((k * pitch + course * pitch / 2.0, 0.0, course, 0.0))
    return _build("pyramid", layout, options)


def _check_count(what: str, value: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise BlueprintError("<generator>", what, f"must be an integer >= 1, got {value!r}")


def _size(options: Site) -> Vec3:
    size = options.brick_size_m
    values = tuple(float(v) for v in size)
    if len(values) != 3 or not all(math.isfinite(v) and v > 0.0 for v in values):
        raise BlueprintError("<generator>", "brick size", f"must be 3 positive numbers, got {size!r}")
    return (values[0], values[1], values[2])


def _cruise_m(options: Site, layout: _Layout, origin: tuple[float, ...], height: float) -> float:
    """The cruise altitude: the option's, else the default, or over the finished wall's top when that is higher."""
    if options.cruise_altitude_m is not None:
        return float(options.cruise_altitude_m)
    top = (
        (origin[2] if len(origin) == 3 else 0.0)
        + max((c for _, _, c, _ in layout), default=0) * height
        + height
    )
    return DEFAULT_CRUISE_ALTITUDE_M if top < DEFAULT_CRUISE_ALTITUDE_M else top + CRUISE_OVER_WALL_M


def _build(kind: str, layout: _Layout, options: Site) -> Blueprint:
    size = _size(options)
    length, width, height = size
    yaw = float(options.yaw_rad)
    origin = tuple(float(v) for v in options.origin_m)
    placed_courses = int(options.placed_courses)
    brick_uavs = int(options.brick_uavs)
    adhesion_uavs = int(options.adhesion_uavs)
    clearance = float(options.clearance_m)
    cruise = _cruise_m(options, layout, origin, height)
    pallet_distance = (
        clearance + 1.0 if options.pallet_distance_m is None else float(options.pallet_distance_m)
    )
    n_spares = int(options.spares or 0)
    markers = options.markers or _markers_for(size, len(layout) + n_spares)
    capacity = marker_capacity(markers)
    if len(origin) not in (2, 3):
        raise BlueprintError("<generator>", "origin", f"must be 2 or 3 numbers, got {origin!r}")
    if placed_courses < 0 or brick_uavs < 0 or adhesion_uavs < 0 or n_spares < 0:
        raise BlueprintError("<generator>", "counts", "placed courses, fleet sizes and spares must be >= 0")
    ox, oy = origin[0], origin[1]
    oz = origin[2] if len(origin) == 3 else 0.0
    cos_y, sin_y = math.cos(yaw), math.sin(yaw)

    def world(u: float, v: float, z: float) -> Vec3:
        return (ox + cos_y * u - sin_y * v, oy + sin_y * u + cos_y * v, oz + z)

    # Centre the wall on the origin along u.
    us = [u for u, _, _, _ in layout]
    u_mid = (min(us) + max(us)) / 2.0
    todo = [i for i, (_, _, course, _) in enumerate(layout) if course >= placed_courses]
    pallet_pitch_u = length + 0.2
    pallet_pitch_v = width + 0.3
    todo_u = [layout[i][0] - u_mid for i in todo]
    span = (max(todo_u) - min(todo_u)) if todo else 0.0
    wall_columns = int(span / pallet_pitch_u + 1e-9) + 1
    if options.pallet_columns or wall_columns < PALLET_MIN_COLUMNS:
        # a short wall (or a pallet of a given width): filled row by row in brick order, 10 columns (20 beyond
        # 40 bricks), wider than the wall, so that the bricks fetched together are spread across it
        columns = int(options.pallet_columns) or max(1, min(len(todo), 10 if len(todo) <= 40 else 20))
        slots = [divmod(k, columns) for k in range(len(todo))]
    else:
        # a long wall: a pallet as wide as the wall, each brick facing its place
        columns = wall_columns
        slots = _pallet_slots(todo_u, _index_in_course(layout, todo), columns, pallet_pitch_u, pallet_pitch_v)

    def pallet(row: int, col: int) -> Vec3:
        u = (col - (columns - 1) / 2.0) * pallet_pitch_u
        v = -(width / 2.0 + pallet_distance + row * pallet_pitch_v)
        return world(u, v, height / 2.0)

    pickups = {index: pallet(row, col) for index, (row, col) in zip(todo, slots)}
    bricks = []
    for index, (u, v, course, rel_yaw) in enumerate(layout):
        placed = course < placed_courses
        bricks.append(
            Brick(
                id=index,
                position_m=world(u - u_mid, v, course * height + height / 2.0),
                size_m=size,
                yaw_rad=yaw + rel_yaw,
                placed=placed,
                pickup_m=None if placed else pickups[index],
            )
        )
    rows = max((row for row, _ in slots), default=-1) + 1
    # the spares in columns of their own at the pallet's +u end, as deep as the pallet: the pads stay where they are
    depth = max(rows, 1)
    spares = tuple(
        Spare(len(layout) + k, pallet(k % depth, columns + k // depth), size) for k in range(n_spares)
    )
    home_v = -(width / 2.0 + pallet_distance + max(rows - 1, 0) * pallet_pitch_v + clearance + 1.0)
    crew: list[tuple[str, Role]] = [(f"brick-{k + 1}", "brick") for k in range(brick_uavs)]
    crew += [(f"glue-{k + 1}", "adhesion") for k in range(adhesion_uavs)]
    step = max(clearance + 0.5, pad_separation_m())
    fleet = tuple(
        UavSpec(name=n, role=r, home_m=world((k - (len(crew) - 1) / 2.0) * step, home_v, 0.0))
        for k, (n, r) in enumerate(crew)
    )
    numbered: tuple[Brick, ...] = tuple(bricks)
    if len(bricks) > capacity:
        # more bricks than marker numbers: reuse them where no camera sees two alike (masonry.marker_reuse), in
        # the smallest dictionary that holds the numbers used unless the options name one
        widest = markers if options.markers else replace(markers, dictionary=_dictionary_for(len(bricks)))
        reused = assign_markers(bricks, widest)
        if reused is not None:
            numbered = reused
            used = 1 + max(b.marker_number for b in reused)
            markers = markers if options.markers else replace(markers, dictionary=_dictionary_for(used))
    name = options.name or f"{kind}-{len(bricks)}"
    return Blueprint(
        bricks=numbered,
        fleet=fleet,
        name=str(name),
        clearance_m=clearance,
        cruise_altitude_m=cruise,
        brick_size_m=size,
        markers=markers,
        source=f"<{kind}>",
        spares=None if options.spares is None else spares,
    )


def _pallet_slots(
    todo_u: list[float], todo_k: list[int], columns: int, pitch_u: float, pitch_v: float
) -> list[tuple[int, int]]:
    """Pallet slots (row, column), in brick order: each brick on the free slot nearest to its target.

    A brick's target is the column facing its place (along-wall coordinate u), in the front row for an even brick of
    its course (``todo_k``, its index in the course) and :data:`PALLET_ROW_STRIDE` rows behind for an odd one
    (fewer if the bricks fill fewer rows). So the carry stays short (the pallet's distance, no walk along it), two
    bricks side by side on the wall -- laid one after the other, the second fetched while the first is laid -- are
    picked up rows apart, and bricks laid at the same time (r_c apart on the wall) about as far apart as laid.
    """
    offset = (columns - 1) / 2.0
    rows = -(-len(todo_u) // columns)
    stride = min(PALLET_ROW_STRIDE, rows - 1)  # no deeper than the bricks fill (a compact pallet)
    free = sorted((r, c) for r in range(rows + stride + 1) for c in range(columns))
    out: list[tuple[int, int]] = []
    for u, k in zip(todo_u, todo_k):
        row = stride * (k % 2)
        best = min(free, key=lambda s: (math.hypot((s[1] - offset) * pitch_u - u, (s[0] - row) * pitch_v), s))
        free.remove(best)
        out.append(best)
    return out


def _index_in_course(layout: _Layout, todo: list[int]) -> list[int]:
    """Each brick's index among its course's bricks (in layout order)."""
    seen: dict[int, int] = {}
    out = []
    for i in todo:
        course = layout[i][2]
        out.append(seen.get(course, 0))
        seen[course] = out[-1] + 1
    return out


def _markers_for(size: Vec3, n_bricks: int) -> MarkerSpec:
    """The default marker layout, shrunk if needed to fit the top face, with a dictionary numbering every brick."""
    default = MarkerSpec()
    scale = min(1.0, 0.9 * size[0] / (default.spacing_m + default.size_m), 0.9 * size[1] / default.size_m)
    return MarkerSpec(
        dictionary=_dictionary_for(n_bricks),
        size_m=round(default.size_m * scale, 4),
        spacing_m=round(default.spacing_m * scale, 4),
    )


def _dictionary_for(n_bricks: int) -> str:
    """The smallest 4x4 ArUco dictionary holding markers 0 .. 2n-1, DICT_APRILTAG_36h10 (2320 markers) beyond 500
    bricks; beyond 1160 bricks, DICT_APRILTAG_36h10 with marker numbers reused (:func:`_build`)."""
    for size in (50, 100, 250, 1000):
        if 2 * n_bricks <= size:
            return f"DICT_4X4_{size}"
    return "DICT_APRILTAG_36h10"


def generate(kind: str, **options: Any) -> Blueprint:
    """Dispatch on the generator name ("running-bond", "towers" or "pyramid")."""
    funcs: dict[str, Callable[..., Blueprint]] = {
        "running-bond": running_bond,
        "towers": towers,
        "pyramid": pyramid,
    }
    if kind not in funcs:
        raise BlueprintError(
            "<generator>", "kind", f"unknown generator {kind!r} (one of {', '.join(GENERATORS)})"
        )
    return funcs[kind](**options)
