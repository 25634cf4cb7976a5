"""Spare bricks: the blueprint's ``spares`` (their pickups and sizes), read, checked and written (pure).

A spare is a brick with an id of its own that belongs to no place in the wall. It carries the markers of its
own id (2k and 2k+1, the rule of every brick), so the camera tells it from the bricks of the wall; when a brick
of the same size is lost (with a UAV, dropped, or not found at its pickup), mission control hands its task
out again with the spare's pickup and id (:mod:`masonry.mission.spares`, docs/blueprint-format.md, "Spares").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from masonry.errors import BlueprintError

Vec3 = tuple[float, float, float]

#: The keys of one spare in the blueprint.
SPARE_KEYS = ("id", "pickup", "size")
#: Two sizes this close (per dimension, metres) are the same size.
SAME_SIZE_TOL_M = 1e-6


@dataclass(frozen=True)
class Spare:
    """One spare brick: its id (its markers are 2*id and 2*id+1), where it waits, and its size."""

    id: int
    pickup_m: Vec3
    size_m: Vec3

    def fits(self, size_m: Vec3) -> bool:
        """Whether it can stand in for a brick of ``size_m`` (the same size, to a micrometre)."""
        return all(
            math.isclose(a, b, rel_tol=0.0, abs_tol=SAME_SIZE_TOL_M) for a, b in zip(self.size_m, size_m)
        )


def parse_spares(raw: object, source: str, default_size_m: Vec3) -> tuple[Spare, ...] | None:
    """The blueprint's ``spares`` list (None: the key is absent; ``[]``: no spare, but the accounting is on).

    Raises:
        BlueprintError: not a list, a spare that is not a mapping, an unknown or missing key, a bad id, pickup
            or size, or an id twice (one line naming the file, the spare and the field).
    """
    if raw is None:
        return None
    if not isinstance(raw, list):
        raise BlueprintError(source, "spares", f"must be a list of spares, got {_kind(raw)}")
    spares: list[Spare] = []
    seen: set[int] = set()
    for index, item in enumerate(raw):
        spare = _spare(item, f"spares[{index}]", source, default_size_m)
        if spare.id in seen:
            raise BlueprintError(source, f"spare {spare.id}", "duplicate spare id")
        seen.add(spare.id)
        spares.append(spare)
    return tuple(spares)


def _spare(raw: object, where: str, source: str, default_size_m: Vec3) -> Spare:
    if not isinstance(raw, Mapping):
        raise BlueprintError(source, where, f"must be a mapping with `id` and `pickup`, got {_kind(raw)}")
    sid = raw.get("id")
    if isinstance(sid, bool) or not isinstance(sid, int) or sid < 0:
        raise BlueprintError(source, f"{where}: id", f"must be an integer >= 0, got {_short(sid)}")
    where = f"spare {sid}"
    for key in raw:
        if key not in SPARE_KEYS:
            raise BlueprintError(
                source, where, f"unknown key {_short(key)}; allowed: {', '.join(SPARE_KEYS)}"
            )
    if "pickup" not in raw:
        raise BlueprintError(source, where, "missing key 'pickup'")
    pickup = _vec3(raw["pickup"], source, f"{where}: pickup", "[x, y, z]")
    size = _vec3(raw["size"], source, f"{where}: size", "[length, width, height]") if "size" in raw else None
    if size is not None and not all(v > 0.0 for v in size):
        raise BlueprintError(source, f"{where}: size", f"every dimension must be > 0, got {list(size)}")
    return Spare(int(sid), pickup, size if size is not None else default_size_m)


def _vec3(raw: object, source: str, where: str, form: str) -> Vec3:
    values = list(raw) if isinstance(raw, (list, tuple)) and len(raw) == 3 else []
    if values and all(
        not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) for v in values
    ):
        return (float(values[0]), float(values[1]), float(values[2]))
    raise BlueprintError(
        source, where, f"must be a list of 3 finite numbers {form} in metres, got {_short(raw)}"
    )


def _kind(value: object) -> str:
    return (
        "a mapping" if isinstance(value, Mapping) else "a list" if isinstance(value, list) else _short(value)
    )


def _short(value: object, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def format_spares(spares: tuple[Spare, ...], default_size_m: Vec3, num: Callable[[float], str]) -> str:
    """The ``spares:`` YAML lines (one flow mapping per spare; ``size`` only where it is not the default);
    ``num`` formats one number as :func:`masonry.blueprint.format_blueprint` does."""
    lines = ["spares:" if spares else "spares: []"]
    for s in spares:
        parts = [f"id: {s.id}", "pickup: [" + ", ".join(num(v) for v in s.pickup_m) + "]"]
        if not s.fits(default_size_m):
            parts.append("size: [" + ", ".join(num(v) for v in s.size_m) + "]")
        lines.append("  - {" + ", ".join(parts) + "}")
    return "\n".join(lines)


__all__ = ["SPARE_KEYS", "Spare", "format_spares", "parse_spares"]
