"""The blueprint's ``adhesive``: how long a bead stays open and how long a joint cures (docs/blueprint-format.md).

Pure: YAML values in, an :class:`Adhesive` or a :class:`~masonry.errors.BlueprintError` out, one line naming the
file, the field (``adhesive.open_time_s``, ``adhesive.cure_time_s``) and the problem. A blueprint without
``adhesive`` has ``Blueprint.adhesive = None`` and plans, schedules and flies exactly as before.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from masonry.errors import BlueprintError

ADHESIVE_KEYS = ("open_time_s", "cure_time_s")
#: Either time at most a day: beyond it is a typing mistake (milliseconds for seconds), not an adhesive.
MAX_ADHESIVE_TIME_S = 86_400.0


@dataclass(frozen=True)
class Adhesive:
    """An adhesive's open time and cure time.

    ``open_time_s``: a brick must start its site visit (its flight down onto the bead) within this time of the
    end of every adhesion task under it (None: the bead never skins over). ``cure_time_s``: nothing is sprayed
    onto (so nothing placed on) a brick before this time has passed since the brick was placed on its glue.
    """

    open_time_s: float | None = None
    cure_time_s: float = 0.0


def parse_adhesive(raw: Any, source: str) -> Adhesive | None:
    """The ``adhesive`` mapping of a blueprint file (None: absent).

    Raises:
        BlueprintError: not a mapping, an unknown key, a time that is not a number in its range.
    """
    from masonry.blueprint import _check_keys, _kind

    if raw is None:
        return None
    if not isinstance(raw, Mapping):
        raise BlueprintError(
            source, "adhesive", f"must be a mapping with `open_time_s` and/or `cure_time_s`, got {_kind(raw)}"
        )
    _check_keys(raw, ADHESIVE_KEYS, (), source, "adhesive")
    if not raw:
        raise BlueprintError(source, "adhesive", "is empty: give `open_time_s` and/or `cure_time_s`")
    open_time = raw.get("open_time_s")
    open_time_s = None if open_time is None else _time(open_time, source, "open_time_s", positive=True)
    cure_time_s = _time(raw.get("cure_time_s", 0.0), source, "cure_time_s", positive=False)
    return Adhesive(open_time_s=open_time_s, cure_time_s=cure_time_s)


def _time(raw: Any, source: str, key: str, *, positive: bool) -> float:
    from masonry.blueprint import _fmt, _number

    where = f"adhesive.{key}"
    value = _number(raw, source, where)
    low_ok = value > 0.0 if positive else value >= 0.0
    if not low_ok or value > MAX_ADHESIVE_TIME_S:
        low = "(0" if positive else "[0"
        raise BlueprintError(
            source, where, f"{_fmt(value)} s is outside {low}, {_fmt(MAX_ADHESIVE_TIME_S)}] s"
        )
    return value


def format_adhesive(adhesive: Adhesive) -> str:
    """The ``adhesive:`` line of a blueprint file (read back by :func:`parse_adhesive`)."""
    parts = []
    if adhesive.open_time_s is not None:
        parts.append(f"open_time_s: {round(adhesive.open_time_s, 9) + 0.0!r}")
    parts.append(f"cure_time_s: {round(adhesive.cure_time_s, 9) + 0.0!r}")
    return "adhesive: {" + ", ".join(parts) + "}"
