"""Where a task's time goes: the phase of a UAV at each tick, from its two machines' states, and its clock.

A UAV runs its task machine (:data:`~masonry.fsm.states.BRICK_STATES`, :data:`~masonry.fsm.states.ADHESION_STATES`)
and, beside it, the airspace transit machine (:data:`~masonry.fsm.states.TRANSIT_STATES`). :func:`phase_of` maps
the pair to one phase of :data:`masonry.ports.PHASES`: a transit asking for its site column is ``waiting``, one
sent to a hold point ``holding``, whatever the task machine's state (it is a lateral move then); otherwise (no
transit, or one granted and flying there) the task machine's state decides. :class:`PhaseClock` adds the time
between two ticks to the phase the UAV was in during it, for the task in hand, so that the phases of an attempt
add up to its duration exactly (docs/mission.md, "Where the time goes").
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from masonry.ports import PHASES, PhaseTimes

#: The phase of each leaf state of both task machines (a transit asking or holding overrides it).
STATE_PHASES: Mapping[str, str] = MappingProxyType(
    {
        # both machines
        "idle": "other",  # a task taken there leaves idle in the same tick
        "takeoff": "takeoff",
        "home": "transit",  # a task taken there turns the UAV back in the same tick
        "land": "other",
        "failsafe": "other",  # the task is reported failed before these: they never hold one
        "emergency": "other",
        "halted": "other",
        # brick UAV (paper, Section IV)
        "pickup_goto": "transit",
        "pickup_estimate": "estimating",
        "pickup_align": "aligning",
        "pickup_descend": "descending",
        "pickup_grasp": "grasping",
        "pickup_ascend": "ascending",
        "pickup_verify": "grasping",  # is the brick on the magnet? (else back to estimate)
        "transport": "transit",
        "place_align": "aligning",
        "place_descend": "descending",
        "place_release": "placing",
        "place_verify": "placing",
        "place_ascend": "ascending",
        "reseat_descend": "descending",  # a brick out of place lifted to be placed again (masonry.fsm.reseat)
        "reseat_grasp": "grasping",
        "reseat_ascend": "ascending",
        "putback_goto": "transit",  # a task given up with the brick on the magnet: it goes back to its pallet
        "putback_descend": "descending",
        "putback_release": "placing",
        "putback_ascend": "ascending",
        # adhesion UAV (paper, Section V)
        "cruise": "transit",
        "hover": "aligning",  # still over the segment's start before the descent
        "descend": "descending",
        "spray": "spraying",
        "close": "spraying",  # the valve closing at the segment's end
        "ascend": "ascending",
    }
)

#: The phase each transit state imposes (None: the task machine's state decides).
TRANSIT_PHASES: Mapping[str, str | None] = MappingProxyType(
    {
        "clear": None,  # no transit
        "ask": "waiting",  # hovering where it stopped until mission control grants the column
        "hold": "holding",  # flying to, or waiting at, a hold point on its layer
        "down": None,  # granted: flying its layer route and coming down there (a route state: ``transit``)
    }
)

_INDEX = {name: i for i, name in enumerate(PHASES)}


def phase_of(state: str, transit: str) -> str:
    """The phase (one of :data:`masonry.ports.PHASES`) of a UAV in task state ``state`` and transit ``transit``.

    Raises:
        KeyError: a state of neither machine.
    """
    imposed = TRANSIT_PHASES[transit]
    return imposed if imposed is not None else STATE_PHASES[state]


#: (task state, transit state) -> the index of its phase in PHASES: :func:`phase_of`, tabulated.
_STATE_INDEX = {
    (state, transit): _INDEX[phase_of(state, transit)] for state in STATE_PHASES for transit in TRANSIT_PHASES
}


class PhaseClock:
    """Seconds per phase of the task in hand, on the machine's own clock (its ticks' times).

    ``start(now_s)`` when the task is taken, ``tick(now_s, phase)`` at every control tick (the time since the
    last tick goes to ``phase``, the one the UAV was in meanwhile), ``stop()`` when it is reported: the phases,
    which add up to ``now_s - start`` of the last tick.
    """

    def __init__(self) -> None:
        self._s = [0.0] * len(PHASES)
        self._mark_s: float | None = None

    @property
    def running(self) -> bool:
        return self._mark_s is not None

    def start(self, now_s: float) -> None:
        """A task is taken at ``now_s``: every phase back to zero."""
        self._s = [0.0] * len(PHASES)
        self._mark_s = now_s

    def tick(self, now_s: float, phase: str) -> None:
        """The time since the last tick (or the start) was spent in ``phase``; nothing while no task runs."""
        mark = self._mark_s
        if mark is None:
            return
        if now_s > mark:
            self._s[_INDEX[phase]] += now_s - mark
        self._mark_s = now_s

    def tick_in(self, now_s: float, state: str, transit: str) -> None:
        """:meth:`tick` with the phase of ``phase_of(state, transit)`` (one lookup: it runs at every control tick)."""
        mark = self._mark_s
        if mark is None:
            return
        if now_s > mark:
            self._s[_STATE_INDEX[state, transit]] += now_s - mark
        self._mark_s = now_s

    def stop(self) -> PhaseTimes:
        """The task is reported: the seconds per phase so far (the clock stops until the next ``start``)."""
        self._mark_s = None
        return PhaseTimes(*self._s)

    def so_far(self) -> PhaseTimes:
        """The seconds per phase so far, the clock running on."""
        return PhaseTimes(*self._s)
