"""The airspace transit of one UAV (docs/safety.md): its record and its machine (:data:`states.TRANSIT_STATES`).

The UAV model runs it beside its task machine: :meth:`Transit.begin` when a lateral move needs the column over
its site, ``wait`` / ``grant`` on mission control's answers, ``arrive`` once down there, ``cancel`` on any other
move. The record holds what the requests carry; the model does the asking (its :class:`~masonry.ports.ClearanceLink`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable

from transitions import Machine

from masonry.fsm.states import TRANSIT_STATES, TRANSIT_TRANSITIONS

Vec3 = tuple[float, float, float]


class Transit:
    """One UAV's transit: phase (``state``: clear, ask, hold, down), site, layer and the work's extent.

    Attributes:
        state: the protocol's phase.
        site_m: where the move goes (the column asked for).
        layer_m: the altitude of its lateral legs once mission control has given one (None: not yet).
        top_m: the highest altitude of the work at the site (None: the site's).
        to_m: where that work ends if it moves along a segment (None: at the site).
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
        self.request()

    def drop(self) -> None:
        """No transit (any more): the UAV moves otherwise, or stops."""
        if self.state != "clear":
            self.cancel()
