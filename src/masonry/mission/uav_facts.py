"""What a UAV says about itself in its heartbeats and progress reports: typed facts, not state names (issue 27 §2).

The UAV side knows its machine (``masonry.fsm``) and turns its state into :class:`UavFacts` (:func:`facts_of`);
mission control decides from the facts alone (the way home a silent UAV flies, whether it took a brick down with
it, how long it may be quiet while it finishes, whether it is down on its pad). The state name still travels with
them, for the log, the report and the live page.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from masonry.ports import CARRYING_STATES, FINISHING_STATES

__all__ = ["LANDED_STATE", "MAY_FINISH_STATES", "OUT_OF_SERVICE_STATE", "UavFacts", "facts_from", "facts_of"]

#: The state of a UAV's machine landed and idle on its pad.
LANDED_STATE = "idle"
#: The state a UAV's machine reports when it is out of service for the rest of the mission.
OUT_OF_SERVICE_STATE = "halted"

#: Last heard in one of these, a silent UAV may be finishing its task (``FINISHING_STATES``, or the descent and
#: the spraying that lead into them): it gets ``rejoin_timeout_s`` more before it is declared lost.
MAY_FINISH_STATES = FINISHING_STATES | {"place_descend", "spray"}


@dataclass(frozen=True)
class UavFacts:
    """A UAV's facts as of its last heartbeat or progress report (all false: nothing reported yet).

    Attributes:
        carrying: a brick is on its magnet (after the grasp, until it is released on the wall or the pallet).
        flying_home: it flies home on its own (its way home, or a brick back to its pallet first).
        on_pad: it is landed and idle on its pad.
        finishing: its work is (or is about to be) on the wall and it finishes it even cut off.
        out_of_service: it is out of service for the rest of the mission (it refuses every task).
    """

    carrying: bool = False
    flying_home: bool = False
    on_pad: bool = False
    finishing: bool = False
    out_of_service: bool = False


def facts_of(state: str) -> UavFacts:
    """The facts of a machine (``masonry.fsm``) in ``state``: the UAV side's reading of its own state."""
    return UavFacts(
        carrying=state in CARRYING_STATES,
        flying_home=state == "home" or state.startswith("putback"),
        on_pad=state == LANDED_STATE,
        finishing=state in MAY_FINISH_STATES,
        out_of_service=state == OUT_OF_SERVICE_STATE,
    )


class _Reports(Protocol):
    """A message that carries a UAV's facts (a heartbeat or a progress report)."""

    @property
    def carrying(self) -> bool: ...
    @property
    def flying_home(self) -> bool: ...
    @property
    def on_pad(self) -> bool: ...
    @property
    def finishing(self) -> bool: ...
    @property
    def out_of_service(self) -> bool: ...


def facts_from(msg: _Reports) -> UavFacts:
    """The facts a heartbeat or progress report carries (mission control's side: it reads no state name)."""
    return UavFacts(msg.carrying, msg.flying_home, msg.on_pad, msg.finishing, msg.out_of_service)
