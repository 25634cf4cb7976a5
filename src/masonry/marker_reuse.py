"""Marker numbers reused across a big wall: unique among the bricks one camera pose can see (issue 30).

Brick k carries ArUco ids 2m and 2m+1, where m is its *marker number*: ``bricks[].marker`` in the blueprint, or its
id when none is given (issue 13's rule, and every wall of at most 1,160 bricks). A wall of more bricks than any
dictionary numbers reuses marker numbers: two bricks may share one only if no single camera pose can see both.

A brick's markers sit at its *sites*: its pickup (while it waits there) and its place on the wall. A camera sees a
marker only within its image and within its detection range, the depth at which the marker shrinks to
``min_marker_px`` pixels (2.5 m for 5 cm markers at 500 px focal length): the visible volume is a pyramid whose
apex is the camera and whose base is the image's footprint at that depth. Two marker centres seen together are
therefore at most the pyramid's widest span apart -- the base's diagonal, 2 x depth x tan(half-diagonal angle), or
the slant edge when it is longer -- whatever the camera's altitude, tilt or yaw (:func:`covisible_distance_m`).
Two bricks whose sites are farther apart than that span plus the marker spacing can never be in one view; a
blueprint may give them the same marker number, and :func:`check_marker_reuse` proves that every pair sharing one
is that far apart. The brick UAV then identifies a brick by its marker ids *and* where it expects it
(:func:`identify_radius_m`), so a reused number is never taken for another brick.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from masonry.blueprint import ARUCO_DICTIONARY_SIZES, Blueprint, Brick, MarkerSpec
from masonry.errors import BlueprintError
from masonry.perception.types import DEFAULT_INTRINSICS, CameraIntrinsics

__all__ = [
    "MIN_MARKER_PX",
    "assign_markers",
    "brick_sites",
    "check_marker_reuse",
    "covisible_distance_m",
    "identify_radius_m",
    "marker_capacity",
    "uses_reuse",
]

#: A marker narrower than this many pixels is not detected (the simulated camera's limit, ``CameraConfig``).
MIN_MARKER_PX = 10.0


def covisible_distance_m(
    markers: MarkerSpec,
    intrinsics: CameraIntrinsics = DEFAULT_INTRINSICS,
    min_marker_px: float = MIN_MARKER_PX,
) -> float:
    """The largest distance between the top-face centres of two bricks whose markers one camera pose can see.

    The widest span of the camera's visible pyramid (depth up to its detection range) plus the marker spacing
    (each marker centre lies ``spacing/2`` from its brick's top-face centre). 4.17 m for the defaults.
    """
    depth_m = max(intrinsics.fx, intrinsics.fy) * markers.size_m / min_marker_px
    tan_x = max(intrinsics.cx, intrinsics.width_px - intrinsics.cx) / intrinsics.fx
    tan_y = max(intrinsics.cy, intrinsics.height_px - intrinsics.cy) / intrinsics.fy
    tan_diag = math.hypot(tan_x, tan_y)
    span_m = depth_m * max(2.0 * tan_diag, math.sqrt(1.0 + tan_diag * tan_diag))
    return span_m + markers.spacing_m


def identify_radius_m(markers: MarkerSpec, intrinsics: CameraIntrinsics = DEFAULT_INTRINSICS) -> float:
    """A brick is taken for the expected one only this close to where it is expected (half the co-visible span).

    Every other brick with the same marker number is more than :func:`covisible_distance_m` from every site of the
    expected brick (:func:`check_marker_reuse`), so it is never within half of it.
    """
    return covisible_distance_m(markers, intrinsics) / 2.0


def marker_capacity(markers: MarkerSpec) -> int:
    """How many marker numbers the dictionary holds (two ArUco ids each)."""
    return ARUCO_DICTIONARY_SIZES[markers.dictionary] // 2


def brick_sites(bricks: Sequence[Brick]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every site of every brick: top-face centres (n, 3), the brick's index (n,) and whether it is a pickup (n,)."""
    points: list[tuple[float, float, float]] = []
    owner: list[int] = []
    pickup: list[bool] = []
    for index, b in enumerate(bricks):
        points.append(b.top_center_m)
        owner.append(index)
        pickup.append(False)
        if b.pickup_m is not None and not b.placed:
            points.append((b.pickup_m[0], b.pickup_m[1], b.pickup_m[2] + b.size_m[2] / 2.0))
            owner.append(index)
            pickup.append(True)
    return (
        np.array(points, dtype=float).reshape(-1, 3),
        np.array(owner, dtype=int),
        np.array(pickup, dtype=bool),
    )


def uses_reuse(bricks: Sequence[Brick]) -> bool:
    """Whether two bricks share a marker number."""
    numbers = [b.marker_number for b in bricks]
    return len(set(numbers)) < len(numbers)


def check_marker_reuse(blueprint: Blueprint, intrinsics: CameraIntrinsics = DEFAULT_INTRINSICS) -> None:
    """Prove that no two bricks one camera pose can see share a marker number.

    Raises:
        BlueprintError: naming the later brick of the first such pair (in blueprint order), its ``marker``, the
            other brick, where the two are and a marker number that brick could take instead.
    """
    bricks = blueprint.bricks
    if not uses_reuse(bricks):
        return
    limit_m = covisible_distance_m(blueprint.markers, intrinsics)
    points, owner, pickup = brick_sites(bricks)
    numbers = np.array([b.marker_number for b in bricks], dtype=np.int64)
    site_numbers = numbers[owner]
    order = np.argsort(site_numbers, kind="stable")
    bounds = np.flatnonzero(np.diff(site_numbers[order])) + 1
    worst: tuple[int, int, int, int] | None = None  # (later brick, earlier brick, its site, the other's site)
    for group in np.split(order, bounds):
        if len(np.unique(owner[group])) < 2:
            continue
        found = _first_pair(group, points, owner, limit_m)
        if found is not None and (worst is None or found[:2] < worst[:2]):
            worst = found
    if worst is None:
        return
    later, earlier, sa, sb = worst
    first, other = bricks[later], bricks[earlier]
    where_a = "pickup" if pickup[sa] else "place on the wall"
    where_b = "pickup" if pickup[sb] else "place on the wall"
    gap_m = float(np.linalg.norm(points[sa] - points[sb]))
    m = first.marker_number
    free = _free_number(later, points, owner, numbers, limit_m, marker_capacity(blueprint.markers))
    advice = (
        f"give it marker {free} (no brick within {limit_m:.2f} m has it)"
        if free is not None
        else f"no marker of {blueprint.markers.dictionary} is free there: choose a larger dictionary"
    )
    raise BlueprintError(
        blueprint.source,
        f"brick {first.id}: marker",
        f"{m} (ArUco ids {2 * m}, {2 * m + 1}) is brick {other.id}'s too, and one camera pose can see both "
        f"(brick {first.id}'s {where_a} is {gap_m:.2f} m from brick {other.id}'s {where_b}; bricks sharing a "
        f"marker must be more than {limit_m:.2f} m apart); {advice}",
    )


def _first_pair(
    group: np.ndarray, points: np.ndarray, owner: np.ndarray, limit_m: float
) -> tuple[int, int, int, int] | None:
    """In one marker number's sites (in brick order), the pair with the earliest later brick, then earliest other.

    Rows are taken in chunks so a number shared by thousands of bricks never builds a whole distance matrix.
    """
    p, who = points[group], owner[group]
    for start in range(0, len(group), _CHUNK):
        rows = slice(start, start + _CHUNK)
        d = np.linalg.norm(p[rows, None, :] - p[None, :, :], axis=2)
        hit = (d <= limit_m) & (who[None, :] < who[rows, None])
        if hit.any():
            r = int(np.flatnonzero(hit.any(axis=1))[0])
            cols = np.flatnonzero(hit[r])
            c = int(cols[np.argmin(who[cols])])
            return int(who[start + r]), int(who[c]), int(group[start + r]), int(group[c])
    return None


#: Sites per block of the distance computation (a block is this many rows by the group's size).
_CHUNK = 256


def _free_number(
    index: int, points: np.ndarray, owner: np.ndarray, numbers: np.ndarray, limit_m: float, capacity: int
) -> int | None:
    """The smallest marker number no brick within ``limit_m`` of brick ``index``'s sites has (None: none)."""
    mine = points[owner == index]
    d = np.linalg.norm(points[:, None, :] - mine[None, :, :], axis=2).min(axis=1)
    taken = set(numbers[owner[(d <= limit_m) & (owner != index)]].tolist())
    return next((m for m in range(capacity) if m not in taken), None)


def assign_markers(
    bricks: Sequence[Brick], markers: MarkerSpec, intrinsics: CameraIntrinsics = DEFAULT_INTRINSICS
) -> tuple[Brick, ...] | None:
    """The bricks with marker numbers reused across the wall, none shared by two a camera can see at once.

    Greedy colouring in brick order of the graph "one pose can see both" (sites within
    :func:`covisible_distance_m`): each brick takes the smallest number none of its numbered neighbours has. None
    when the dictionary runs out (a larger one is needed).
    """
    from scipy.spatial import cKDTree

    limit_m = covisible_distance_m(markers, intrinsics)
    capacity = marker_capacity(markers)
    points, owner, _ = brick_sites(bricks)
    tree = cKDTree(points)
    colour = np.full(len(bricks), -1, dtype=np.int64)
    site_lists = tree.query_ball_point(points, r=limit_m)
    first_site = np.searchsorted(owner, np.arange(len(bricks)))
    last_site = np.searchsorted(owner, np.arange(len(bricks)), side="right")
    for index in range(len(bricks)):
        near: list[int] = []
        for s in range(first_site[index], last_site[index]):
            near.extend(site_lists[s])
        used = colour[owner[np.asarray(near, dtype=int)]]
        free = np.ones(capacity + 1, dtype=bool)
        free[used[used >= 0]] = False
        m = int(np.argmax(free[:capacity])) if free[:capacity].any() else -1
        if m < 0:
            return None
        colour[index] = m
    return tuple(replace(b, marker=int(c)) for b, c in zip(bricks, colour.tolist()))
