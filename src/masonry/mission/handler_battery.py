"""The battery reserve and the ground crew of a UAV's mission handler.

With a ``battery`` and a ``swap_battery`` (the simulator's ground crew), the handler keeps a battery reserve:
below ``reserve_fraction`` a queued task is held back, so the machine flies home and lands, and starts once
the pack is swapped (mission control sees the task in progress meanwhile). That hold is the ``queued`` phase
the handler adds to the machine's phases in the result (docs/mission.md, "Where the time goes").
Landed with nothing to do and under ``top_up_fraction``, the pack is swapped on the pad (docs/dispatch.md,
"Battery swaps one after another"). The same crew takes a brick off a UAV that flew home with it.

:class:`GroundCrew` is a base class of :class:`~masonry.mission.handler.UavHandler` (as
:mod:`masonry.mission.handler_columns` and :mod:`masonry.mission.handler_results` are).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from masonry.mission.handler_base import HandlerBase
from masonry.planner.tasks import Task

log = logging.getLogger("masonry.mission.handler")

__all__ = ["TOP_UP_FRACTION", "GroundCrew"]

#: An idle UAV on its pad with less charge than this has its pack swapped there (``UavHandler.top_up_fraction``;
#: the line under which mission control sends a UAV home early, ``masonry.mission.swap_stagger.SWAP_EARLY``).
TOP_UP_FRACTION = 0.5


class GroundCrew(HandlerBase):
    """The UAV's battery as the handler sees it, and the ground crew that swaps it (see the module)."""

    def _init_battery(
        self,
        battery: Callable[[], float] | None,
        swap_battery: Callable[[], bool] | None,
        return_brick: Callable[[int], bool] | None,
        report_battery: Callable[[], float] | None,
        reserve_fraction: float,
        top_up_fraction: float,
    ) -> None:
        self._battery = battery
        self._swap_battery = swap_battery
        self._return_brick = return_brick
        self.bricks_returned: list[int] = []  # bricks the ground crew took off this UAV back to their pickup
        #: what the heartbeats say of the battery (the reserve's, or ``report_battery``'s)
        self._report_battery = report_battery if report_battery is not None else battery
        self.reserve_fraction = reserve_fraction
        self.top_up_fraction = top_up_fraction
        self.battery_swaps = 0
        self.top_ups = 0  # the swaps made while idle on the pad (``top_up_fraction``)
        self._held_for: str | None = None  # why the battery budget holds the next task (logged once)

    @property
    def swaps_batteries(self) -> bool:
        """A ground crew swaps the battery before a task starts (the reserve): a low battery needs no retirement.

        The state machine reads this: with it, a battery run low in the air (e.g. waiting for a site column)
        aborts the task and lands the UAV at home, where the next task it is handed waits for the swap,
        instead of taking the UAV out of service.
        """
        return self._battery is not None and self._swap_battery is not None

    def return_brick(self, brick_id: int) -> bool:
        """The ground crew takes brick ``brick_id`` off the landed UAV and back to its pickup (True once done).

        Only a ground crew that swaps batteries does this (``swaps_batteries``); without one, False: the brick
        stays on the UAV's pad for a person.
        """
        if not self.swaps_batteries or self._return_brick is None or not self._return_brick(brick_id):
            return False
        self.bricks_returned.append(brick_id)
        log.info("%s: ground crew returned brick %d to its pickup", self.name, brick_id)
        return True

    def _held_for_swap(self, task: Task) -> bool:
        """Battery reserve: ``task`` waits (True) while the machine, given nothing, flies home and lands; then
        the ground crew (``swap_battery``, True once done) swaps the pack and the task starts (False)."""
        if self._battery is None or self.out_of_service or not self._needs_swap(task):
            return False
        if self._swap_battery is None or not self._swap_battery():
            return True
        self.battery_swaps += 1
        return False

    def _top_up_while_idle(self) -> None:
        """Idle on its pad with nothing to do and under ``top_up_fraction``: the ground crew swaps the pack now,
        off the critical path, rather than when the next task is held for it (a task handed over meanwhile
        that the battery covers starts at once: the swap is abandoned)."""
        if (
            self._battery is None
            or self._swap_battery is None
            or self.mission_ended
            or self.out_of_service
            or self._battery() >= self.top_up_fraction
        ):
            return
        if self._swap_battery():
            self.battery_swaps += 1
            self.top_ups += 1
            log.info("%s: battery swapped while idle on its pad at %.0f s", self.name, self.now_s)

    def _needs_swap(self, task: Task) -> bool:
        """The battery is under ``reserve_fraction``, or (with a ground crew) does not cover ``task``: the
        machine's battery budget (its ``battery_shortfall``: the task's flight, a budget of waiting for
        clearance and the way home, at the drain it has measured; docs/state-machines.md, "Battery budget")."""
        assert self._battery is not None
        if self._battery() < self.reserve_fraction:
            return True
        shortfall = getattr(self.model, "battery_shortfall", None)
        if self._swap_battery is None or shortfall is None:
            return False
        why = shortfall(task)
        if why is not None and why != self._held_for:
            log.info("%s: %s holds it for a battery swap", self.name, why)
        self._held_for = why
        return why is not None
