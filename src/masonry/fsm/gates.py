"""The gate states' extra exit checks, declared as data: the swing gate of the hover and alignment states.

A *gate* state (``pickup_align``, ``place_align``, ``hover``) is left when the UAV has settled where it should be.
Its work tests that first; if the UAV has not, the gates declared for the state run, in order, each a small pure
function ``check(now_s, telemetry, gated) -> str | None`` that returns the reason to fail the attempt; then the
state's leg timeout. They are not watchdogs (:mod:`masonry.fsm.watchdogs`, which run before the state's work):
which reason wins on a tick where the UAV both settles and swings is part of the pinned behaviour (a watchdog
would fail the attempt that the state passes; docs/state-machines.md, "Watchdogs"). ``masonry fsm diagram``
draws them with the watchdogs. The running mean a check reads is the model's bookkeeping
(:meth:`masonry.fsm.common.CommonStates._gate_failure`), kept before the checks run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from masonry.fsm.attempt import Swing
from masonry.fsm.config import UavConfig
from masonry.ports import Telemetry

#: A swinging UAV this far off its point when a gate fails was blown off (a position loop too fast for its
#: autopilot swings about the point, tens of centimetres; gusts in moderate turbulence carried UAVs 1-40 m).
BLOWN_OFF_M = 1.0


class Gated(Protocol):
    """What a gate check may read of the UAV (the model; read only)."""

    @property
    def config(self) -> UavConfig: ...
    @property
    def swing(self) -> Swing: ...
    @property
    def leg_end_s(self) -> float: ...
    @property
    def hold_target_m(self) -> np.ndarray: ...


GateCheck = Callable[[float, Telemetry, Gated], "str | None"]


@dataclass(frozen=True)
class Gate:
    """A named exit check of the gate states it names (full leaf names, ``pickup_align``)."""

    name: str
    states: tuple[str, ...]
    check: GateCheck

    def guards(self, state: str) -> bool:
        return state in self.states


def swing_gate(now_s: float, tel: Telemetry, g: Gated) -> str | None:
    """The UAV swings instead of settling: past ``swing_patience_s`` after the leg's planned end, the root of its
    mean squared speed over ``swing_window_s`` (exponentially weighted, from the state's entry; the speed over the
    axes its machine's ``SWING_AXES`` names: horizontal for the brick UAV's alignments) is above
    ``swing_speed_mps``. The reason says whether it was blown off (more than :data:`BLOWN_OFF_M` off its point) or
    swings about it (a position loop too fast for the autopilot's lag, or gusts)."""
    cfg = g.config
    mean_sq = g.swing.mean_sq_mps2
    if now_s < g.leg_end_s + cfg.swing_patience_s or mean_sq <= cfg.swing_speed_mps**2:
        return None
    off_m = math.dist(tel.position_m, g.hold_target_m)
    head = (
        f"swinging at {math.sqrt(mean_sq):.2f} m/s rms, {off_m:.2f} m off, "
        f"{now_s - g.leg_end_s:.0f} s after the leg's end: "
    )
    if off_m > BLOWN_OFF_M:
        # a loop too fast for its autopilot swings about the point; this far off, the air moved it (issue 18)
        return head + "blown off by gusts beyond what the autopilot holds against"
    return head + (
        "the position loop is too fast for this autopilot's lag (measure it: masonry fly --identify; "
        "docs/hardware.md), or gusts"
    )


BRICK_GATES: tuple[Gate, ...] = (Gate("swing", ("pickup_align", "place_align"), swing_gate),)
ADHESION_GATES: tuple[Gate, ...] = (Gate("swing", ("hover",), swing_gate),)
#: The declared gates per machine (for the models and the diagrams).
GATES: dict[str, tuple[Gate, ...]] = {"brick": BRICK_GATES, "adhesion": ADHESION_GATES}


def for_kind(kind: str) -> tuple[Gate, ...]:
    """The gates a UAV of ``kind`` runs (none for another kind)."""
    return GATES.get(kind, ())


def gated_states(kind: str) -> list[tuple[str, tuple[str, ...]]]:
    """Each gate of machine ``kind`` and the states it guards, as the diagrams label them."""
    return [(gate.name, gate.states) for gate in GATES.get(kind, ())]


__all__ = [
    "ADHESION_GATES",
    "BLOWN_OFF_M",
    "BRICK_GATES",
    "GATES",
    "Gate",
    "GateCheck",
    "Gated",
    "for_kind",
    "gated_states",
    "swing_gate",
]
