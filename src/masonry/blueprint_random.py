"""Random site layouts for property tests and sweeps: the layouts users bring, not only the bundled style.

:func:`random_layout` draws a wall (running bond, towers or a pyramid), a clearance r_c, a pallet on any side of
the wall, a fleet of 1-6 UAVs per role on a grid of pads as tight as the validation allows (or looser), and a
rotation and a place on the site; the result is validated like any blueprint file (what validates must fly:
``tests/test_random_layouts.py`` flies them, ``benchmarks/bench_layouts.py`` sweeps many more).

Pure: a :class:`random.Random` in, a :class:`~masonry.blueprint.Blueprint` out.
"""

from __future__ import annotations

import dataclasses
import math
import random
from collections.abc import Sequence

from masonry.blueprint import Blueprint, Brick, UavSpec, validate_blueprint
from masonry.blueprint_gen import pyramid, running_bond, towers
from masonry.separation import pad_separation_m, pad_site_distance_m

Vec3 = tuple[float, float, float]

#: The sides of the wall (in its own frame: the wall along +u, its face towards -v).
SIDES = ("south", "north", "east", "west")


@dataclasses.dataclass(frozen=True)
class LayoutLimits:
    """How large the random layouts get (small for CI, larger for a sweep)."""

    max_courses: int = 3
    max_per_course: int = 5
    max_uavs_per_role: int = 6
    clearance_m: tuple[float, float] = (0.5, 2.0)


def random_layout(rng: random.Random, limits: LayoutLimits = LayoutLimits()) -> Blueprint:
    """A random valid blueprint (see the module docstring)."""
    clearance = round(rng.uniform(*limits.clearance_m), 3)
    kind = rng.choice(("running-bond", "towers", "pyramid"))
    if kind == "running-bond":
        courses = rng.randint(2, limits.max_courses)
        wall = running_bond(
            courses,
            rng.randint(2, limits.max_per_course),
            placed_courses=rng.randint(0, 1),
            clearance_m=clearance,
        )
    elif kind == "towers":
        wall = towers(
            rng.randint(1, 3),
            rng.randint(2, limits.max_courses),
            spacing_m=round(rng.uniform(0.6, 2.5), 2),
            clearance_m=clearance,
            placed_courses=rng.randint(0, 1),
        )
    else:
        wall = pyramid(
            rng.randint(2, limits.max_per_course), clearance_m=clearance, placed_courses=rng.randint(0, 1)
        )
    bricks = _pallet_on(wall.bricks, rng.choice(SIDES))
    n_brick = rng.randint(1, limits.max_uavs_per_role)
    n_glue = rng.randint(1, limits.max_uavs_per_role)
    fleet = _pads(bricks, clearance, n_brick, n_glue, rng)
    yaw = rng.uniform(-math.pi, math.pi)
    shift = (rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0))
    out = dataclasses.replace(
        wall,
        bricks=tuple(
            dataclasses.replace(
                b,
                position_m=_move(b.position_m, yaw, shift),
                yaw_rad=b.yaw_rad + yaw,
                pickup_m=None if b.pickup_m is None else _move(b.pickup_m, yaw, shift),
            )
            for b in bricks
        ),
        fleet=tuple(dataclasses.replace(u, home_m=_move(u.home_m, yaw, shift)) for u in fleet),
        name=f"random-{kind}-{len(bricks)}",
        source="<random layout>",
    )
    validate_blueprint(out)
    return out


def _move(p: Sequence[float], yaw: float, shift: tuple[float, float]) -> Vec3:
    c, s = math.cos(yaw), math.sin(yaw)
    return (c * p[0] - s * p[1] + shift[0], s * p[0] + c * p[1] + shift[1], float(p[2]))


def _box(points: list[Sequence[float]]) -> tuple[float, float, float, float]:
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    return min(xs), max(xs), min(ys), max(ys)


def _footprint(bricks: Sequence[Brick]) -> tuple[float, float, float, float]:
    """The wall's bounding box (every brick's corners), in the generator's frame (the wall along x)."""
    corners: list[Sequence[float]] = []
    for b in bricks:
        hx, hy = b.size_m[0] / 2.0, b.size_m[1] / 2.0
        c, s = math.cos(b.yaw_rad), math.sin(b.yaw_rad)
        for du, dv in ((hx, hy), (hx, -hy), (-hx, hy), (-hx, -hy)):
            corners.append((b.position_m[0] + c * du - s * dv, b.position_m[1] + s * du + c * dv))
    return _box(corners)


def _pallet_on(bricks: Sequence[Brick], side: str) -> tuple[Brick, ...]:
    """Move the generated pallet (south of the wall) to ``side``, as far from the wall as it was."""
    x0, x1, y0, y1 = _footprint(bricks)
    xc = (x0 + x1) / 2.0

    def moved(p: Vec3) -> Vec3:
        off = y0 - p[1]  # how far south of the wall's face
        along = p[0] - xc
        if side == "north":
            return (p[0], y1 + off, p[2])
        if side == "east":
            return (x1 + off, along, p[2])
        if side == "west":
            return (x0 - off, along, p[2])
        return p

    return tuple(
        b if b.pickup_m is None else dataclasses.replace(b, pickup_m=moved(b.pickup_m)) for b in bricks
    )


def _pads(
    bricks: Sequence[Brick], clearance: float, n_brick: int, n_glue: int, rng: random.Random
) -> list[UavSpec]:
    """A grid of pads on a random side, beyond the wall and the pallet, spaced at least what validation allows."""
    fx0, fx1, fy0, fy1 = _footprint(bricks)
    points: list[Sequence[float]] = [(fx0, fy0), (fx1, fy1)]
    points += [b.pickup_m for b in bricks if b.pickup_m is not None]
    x0, x1, y0, y1 = _box(points)
    spacing = pad_separation_m() if rng.random() < 0.4 else round(rng.uniform(pad_separation_m(), 2.5), 3)
    gap = pad_site_distance_m(clearance) + rng.uniform(0.0, 1.0)
    names = [(f"brick-{k + 1}", "brick") for k in range(n_brick)] + [
        (f"glue-{k + 1}", "adhesion") for k in range(n_glue)
    ]
    rng.shuffle(names)
    cols = rng.randint(1, len(names))
    side = rng.choice(SIDES)
    out = []
    for k, (name, role) in enumerate(names):
        i, j = k % cols, k // cols
        across = (i - (cols - 1) / 2.0) * spacing
        if side == "south":
            p = ((x0 + x1) / 2.0 + across, y0 - gap - j * spacing)
        elif side == "north":
            p = ((x0 + x1) / 2.0 + across, y1 + gap + j * spacing)
        elif side == "east":
            p = (x1 + gap + j * spacing, (y0 + y1) / 2.0 + across)
        else:
            p = (x0 - gap - j * spacing, (y0 + y1) / 2.0 + across)
        out.append(UavSpec(name, role, (p[0], p[1], 0.0)))  # type: ignore[arg-type]
    return out


__all__ = ["SIDES", "LayoutLimits", "random_layout"]
