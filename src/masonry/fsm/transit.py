"""The airspace transit of one UAV (docs/safety.md): its record and its machine (:data:`states.TRANSIT_STATES`).

The UAV model runs it beside its task machine: :meth:`Transit.begin` when a lateral move needs the column over
its site, ``wait`` / ``grant`` on mission control's answers, ``arrive`` once down there, ``cancel`` on any other
move. The record holds what the requests carry; the model does the asking (its :class:`~masonry.ports.ClearanceLink`).
"""

from __future__ import annotations

import copy
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from transitions import Machine

from masonry.fsm.states import TRANSIT_STATES, TRANSIT_TRANSITIONS
from masonry.ports import PlanProgress

Vec3 = tuple[float, float, float]

#: A leg shorter than this horizontally is vertical (a climb or a descent); a UAV flies the leg whose end its
#: navigator's target is within this of (horizontally and vertically).
SAME_POINT_M = 0.05


@dataclass(frozen=True)
class Flight:
    """The flight of one of mission control's numbered answers, as the UAV flies it: its legs, in order, each
    ``(leg, start, end)`` with ``leg`` an index of :data:`~masonry.ports.PLAN_LEGS`."""

    grant: int
    legs: tuple[tuple[int, Vec3, Vec3], ...]


def flight_of(grant: int, points: Sequence[Vec3]) -> Flight:
    """The flight through ``points`` (where the UAV is, then the end of each of its legs): a leg that moves it
    horizontally is its transit; a vertical one before it its climb (up or down to its layer), after it its
    descent; with no transit, a leg up is a climb and one down a descent."""
    pairs = list(itertools.pairwise(points))
    moves = [math.hypot(b[0] - a[0], b[1] - a[1]) > SAME_POINT_M for a, b in pairs]
    first = moves.index(True) if any(moves) else None
    legs: list[tuple[int, Vec3, Vec3]] = []
    for i, (a, b) in enumerate(pairs):
        if moves[i]:
            leg = 1
        elif first is not None:
            leg = 0 if i < first else 2
        else:
            leg = 2 if b[2] < a[2] else 0
        legs.append((leg, a, b))
    return Flight(grant, tuple(legs))


def progress_on(flight: Flight, target_m: Vec3, legs_left: int, position_m: Vec3) -> PlanProgress | None:
    """Where a UAV at ``position_m`` is along ``flight``, its navigator flying to ``target_m`` with ``legs_left``
    legs after it: the leg that ends there (the ``legs_left``-th from the flight's end) and the fraction of it
    behind the UAV; None when the navigator flies none of the flight's legs (it stopped, turned back, or moves
    otherwise)."""
    i = len(flight.legs) - 1 - legs_left
    if not 0 <= i < len(flight.legs):
        return None
    leg, a, b = flight.legs[i]
    if math.dist(b, target_m) > SAME_POINT_M:
        return None
    d = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
    n2 = d[0] ** 2 + d[1] ** 2 + d[2] ** 2
    if n2 <= 1e-12:
        return PlanProgress(flight.grant, leg, 1.0)
    f = ((position_m[0] - a[0]) * d[0] + (position_m[1] - a[1]) * d[1] + (position_m[2] - a[2]) * d[2]) / n2
    return PlanProgress(flight.grant, leg, min(1.0, max(0.0, f)) if math.isfinite(f) else 0.0)


class Transit:
    """One UAV's transit: phase (``state``: clear, ask, hold, down), site, layer and the work's extent.

    Attributes:
        state: the protocol's phase.
        site_m: where the move goes (the column asked for).
        layer_m: the altitude of its lateral legs once mission control has given one (None: not yet).
        top_m: the highest altitude of the work at the site (None: the site's).
        to_m: where that work ends if it moves along a segment (None: at the site).
        flight: the flight of mission control's last numbered answer it flies (None: none, or it arrived).
    """

    state: str
    request: Callable[..., bool]
    wait: Callable[..., bool]
    grant: Callable[..., bool]
    arrive: Callable[..., bool]
    cancel: Callable[..., bool]

    def __init__(self, *, ignore_invalid_triggers: bool = True) -> None:
        self.site_m: Vec3 = (0.0, 0.0, 0.0)
        self.layer_m: float | None = None
        self.top_m: float | None = None
        self.to_m: Vec3 | None = None
        self.flight: Flight | None = None
        self.machine = Machine(
            model=self,
            states=copy.deepcopy(TRANSIT_STATES),
            transitions=copy.deepcopy(TRANSIT_TRANSITIONS),
            initial="clear",
            auto_transitions=False,
            ignore_invalid_triggers=ignore_invalid_triggers,
        )

    @property
    def active(self) -> bool:
        """A transit is under way (asked for, holding or coming down)."""
        return self.state != "clear"

    def begin(self, site_m: Vec3, top_m: float | None, to_m: Vec3 | None) -> None:
        """A new move to ``site_m``: ask for its column (the layer is mission control's to give)."""
        self.site_m = site_m
        self.layer_m = None
        self.top_m = top_m
        self.to_m = to_m
        self.flight = None
        self.request()

    def drop(self) -> None:
        """No transit (any more): the UAV moves otherwise, or stops."""
        self.flight = None
        if self.state != "clear":
            self.cancel()
