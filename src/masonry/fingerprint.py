"""Canonical digests of a blueprint: the wall's and the fleet's, for journals and mission messages.

A digest is the SHA-256 of a canonical JSON text of the *parsed* values (not of the file), so that two files
that mean the same wall (other key order, comments, ``0.30`` written as ``0.3``, YAML or JSON) have the same
digest, and any change a planner or a UAV would see (a brick moved by a nanometre, another clearance, another
marker dictionary) changes it. Floats are rounded to the nanometre first, as :func:`format_blueprint` writes
them. The ``name`` and ``source`` of a blueprint are not part of either digest.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from masonry.blueprint import Blueprint

#: characters of the hex digest kept (64 bits: a collision between two walls is not a practical concern)
DIGEST_CHARS = 16


def _num(value: float) -> float:
    return round(float(value), 9) + 0.0  # + 0.0 turns -0.0 into 0.0


def _vec(values: tuple[float, ...] | None) -> list[float] | None:
    return None if values is None else [_num(v) for v in values]


def _digest(value: Any) -> str:
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:DIGEST_CHARS]


def wall_digest(blueprint: Blueprint) -> str:
    """The digest of everything about the wall a task depends on: bricks, pickups, clearance, cruise, markers, adhesive,
    spares."""
    m = blueprint.markers
    wall: dict[str, Any] = {
        "clearance_m": _num(blueprint.clearance_m),
        "cruise_altitude_m": _num(blueprint.cruise_altitude_m),
        "brick_size_m": _vec(blueprint.brick_size_m),
        "markers": [m.dictionary, _num(m.size_m), _num(m.spacing_m)],
        "bricks": [
            [b.id, _vec(b.position_m), _vec(b.size_m), _num(b.yaw_rad), b.placed, _vec(b.pickup_m)]
            for b in blueprint.bricks
        ],
    }
    if blueprint.adhesive is not None:  # absent: the digest of every wall written before it existed
        a = blueprint.adhesive
        wall["adhesive"] = [None if a.open_time_s is None else _num(a.open_time_s), _num(a.cure_time_s)]
    if blueprint.spares is not None:  # (as the adhesive: absent, the digest of old)
        wall["spares"] = [[s.id, _vec(s.pickup_m), _vec(s.size_m)] for s in blueprint.spares]
    if any(b.marker is not None for b in blueprint.bricks):  # absent: as before marker numbers existed
        wall["marker_numbers"] = [b.marker_number for b in blueprint.bricks]
    return _digest(wall)


def fleet_digest(blueprint: Blueprint) -> str:
    """The digest of the fleet: each UAV's name, role and home, in the blueprint's order."""
    return _digest([[u.name, u.role, _vec(u.home_m)] for u in blueprint.fleet])
