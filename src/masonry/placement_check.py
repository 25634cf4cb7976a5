"""The blueprint's check of each placed brick against its design (issue 30): ``placement_tolerance_m`` and
``on_placement_error`` (docs/blueprint-format.md, "As-built check").

After each release the brick UAV estimates the brick's pose (its *as-built* pose, ``masonry.fsm.as_built``). A
brick whose as-built centre is farther than ``placement_tolerance_m`` from its designed centre is a
``placement`` event the operator sees (the live page, the log); ``on_placement_error`` says what the mission does
then: ``continue`` (the default) flies on, ``hold`` pauses dispatching as the operator's ``pause`` does (the UAVs
finish the task in hand and wait) until the operator resumes.

``plan_on_as_built`` (default false) plans the work on what was built (:mod:`masonry.planner.as_built_plan`): a
brick's target keeps its designed offsets to the as-built bricks under it, pulled back toward the design by
``as_built_pullback_m`` per course (default 5 mm), never farther from the design than ``placement_tolerance_m``;
an adhesion segment moves with the two bricks it joins.

Pure: YAML values in, a :class:`PlacementCheck` or a :class:`~masonry.errors.BlueprintError` out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from masonry.errors import BlueprintError

if TYPE_CHECKING:
    from masonry.blueprint import Brick

PLACEMENT_KEYS = ("placement_tolerance_m", "on_placement_error", "plan_on_as_built", "as_built_pullback_m")
DEFAULT_PLACEMENT_TOLERANCE_M = 0.02
#: How much nearer its design each course's target is brought than its supports' as-built poses would put it.
DEFAULT_AS_BUILT_PULLBACK_M = 0.005
#: A pull-back above this is a unit mistake: it would put every target on its design (planning off).
MAX_AS_BUILT_PULLBACK_M = 0.05
ON_PLACEMENT_ERROR = ("continue", "hold")
#: A tolerance above this is a unit mistake (centimetres for metres), not a tolerance.
MAX_PLACEMENT_TOLERANCE_M = 1.0

OnPlacementError = Literal["continue", "hold"]
#: How a brick UAV's refused release begins its failure reason (``masonry.fsm.place_taken``: a brick of the wall
#: seen in the drop-off's footprint); mission control does not try such a task again.
PLACE_TAKEN = "place taken:"


def is_place_taken(reason: str) -> bool:
    """Whether a failure ``reason`` is a release refused onto a taken place (not to be tried again)."""
    return reason.startswith(PLACE_TAKEN)


@dataclass(frozen=True)
class PlacementCheck:
    """How far a placed brick may be from its design (``tolerance_m``) and what a brick beyond it does."""

    tolerance_m: float = DEFAULT_PLACEMENT_TOLERANCE_M
    on_error: OnPlacementError = "continue"
    #: plan targets and adhesion segments on the as-built poses (``plan_on_as_built``)
    plan_on_as_built: bool = False
    #: the pull-back toward the design per course (``as_built_pullback_m``)
    pullback_m: float = DEFAULT_AS_BUILT_PULLBACK_M

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
    if action != "continue" and action != "hold":
        raise BlueprintError(source, "on_placement_error", f"must be continue or hold, got {_short(action)}")
    on = data.get("plan_on_as_built", False)
    if not isinstance(on, bool):
        raise BlueprintError(source, "plan_on_as_built", f"must be true or false, got {_short(on)}")
    pullback = DEFAULT_AS_BUILT_PULLBACK_M
    raw = data.get("as_built_pullback_m")
    if raw is not None:
        if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw):
            raise BlueprintError(
                source, "as_built_pullback_m", f"must be a number of metres, got {_short(raw)}"
            )
        pullback = float(raw)
        if not 0.0 <= pullback <= MAX_AS_BUILT_PULLBACK_M:
            raise BlueprintError(
                source,
                "as_built_pullback_m",
                f"{pullback:.6g} m is outside [0, {MAX_AS_BUILT_PULLBACK_M:g}] m",
            )
    return PlacementCheck(tolerance, action, on, pullback)


def placement_lines(check: PlacementCheck, num: Callable[[float], str]) -> list[str]:
    """The blueprint file's lines of a check that is not the default (``num`` writes a number); the as-built
    planning keys only when they are not their defaults (files written before them read back the same)."""
    lines = [f"placement_tolerance_m: {num(check.tolerance_m)}", f"on_placement_error: {check.on_error}"]
    if check.plan_on_as_built:
        lines.append("plan_on_as_built: true")
    if check.pullback_m != DEFAULT_AS_BUILT_PULLBACK_M:
        lines.append(f"as_built_pullback_m: {num(check.pullback_m)}")
    return lines


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
    "DEFAULT_AS_BUILT_PULLBACK_M",
    "DEFAULT_PLACEMENT_TOLERANCE_M",
    "MAX_AS_BUILT_PULLBACK_M",
    "MAX_PLACEMENT_TOLERANCE_M",
    "ON_PLACEMENT_ERROR",
    "PLACEMENT_KEYS",
    "PLACE_TAKEN",
    "PlacementCheck",
    "is_place_taken",
    "parse_placement_check",
    "placement_lines",
    "wall_tops_m",
]
