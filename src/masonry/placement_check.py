"""The blueprint's check of each placed brick against its design (issue 30): ``placement_tolerance_m`` and
``on_placement_error`` (docs/blueprint-format.md, "As-built check").

After each release the brick UAV estimates the brick's pose (its *as-built* pose, ``masonry.fsm.as_built``). A
brick whose as-built centre is farther than ``placement_tolerance_m`` from its designed centre is a
``placement`` event the operator sees (the live page, the log); ``on_placement_error`` says what the mission does
then: ``continue`` (the default) flies on, ``hold`` pauses dispatching as the operator's ``pause`` does (the UAVs
finish the task in hand and wait) until the operator resumes.

Pure: YAML values in, a :class:`PlacementCheck` or a :class:`~masonry.errors.BlueprintError` out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from masonry.errors import BlueprintError

if TYPE_CHECKING:
    from masonry.blueprint import Brick

PLACEMENT_KEYS = ("placement_tolerance_m", "on_placement_error")
DEFAULT_PLACEMENT_TOLERANCE_M = 0.02
ON_PLACEMENT_ERROR = ("continue", "hold")
#: A tolerance above this is a unit mistake (centimetres for metres), not a tolerance.
MAX_PLACEMENT_TOLERANCE_M = 1.0

OnPlacementError = Literal["continue", "hold"]


@dataclass(frozen=True)
class PlacementCheck:
    """How far a placed brick may be from its design (``tolerance_m``) and what a brick beyond it does."""

    tolerance_m: float = DEFAULT_PLACEMENT_TOLERANCE_M
    on_error: OnPlacementError = "continue"

    def beyond(self, deviation_m: float) -> bool:
        """Whether a brick ``deviation_m`` from its design is beyond the tolerance."""
        return deviation_m > self.tolerance_m


def parse_placement_check(data: Mapping[str, object], source: str) -> PlacementCheck:
    """The check from a blueprint file's top-level ``placement_tolerance_m`` and ``on_placement_error``.

    Raises:
        BlueprintError: a tolerance that is not a number in (0, 1] m, or an action other than continue/hold.
    """
    tolerance = DEFAULT_PLACEMENT_TOLERANCE_M
    raw = data.get("placement_tolerance_m")
    if raw is not None:
        if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw):
            raise BlueprintError(
                source, "placement_tolerance_m", f"must be a number of metres, got {_short(raw)}"
            )
        tolerance = float(raw)
        if not 0.0 < tolerance <= MAX_PLACEMENT_TOLERANCE_M:
            raise BlueprintError(
                source,
                "placement_tolerance_m",
                f"{tolerance:.6g} m is outside (0, {MAX_PLACEMENT_TOLERANCE_M:g}] m",
            )
    action = data.get("on_placement_error", "continue")
    if action == "continue" or action == "hold":
        return PlacementCheck(tolerance, action)
    raise BlueprintError(source, "on_placement_error", f"must be continue or hold, got {_short(action)}")


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def wall_tops_m(bricks: Sequence[Brick]) -> tuple[tuple[int, tuple[float, float, float]], ...]:
    """Each brick's marker number and designed top-face centre, for the UAVs that align on the wall's markers
    (``UavConfig.wall``); none when the blueprint reuses marker numbers (a number names no single brick there)."""
    if any(b.marker is not None for b in bricks):
        return ()
    return tuple(
        (b.id, (b.position_m[0], b.position_m[1], b.position_m[2] + b.size_m[2] / 2)) for b in bricks
    )


__all__ = [
    "DEFAULT_PLACEMENT_TOLERANCE_M",
    "MAX_PLACEMENT_TOLERANCE_M",
    "ON_PLACEMENT_ERROR",
    "PLACEMENT_KEYS",
    "PlacementCheck",
    "parse_placement_check",
    "wall_tops_m",
]
