"""What mission control and its desks ask of each other, as typed Protocols (issue 27 §2: no ``Any``).

:class:`WindGate` is what mission control asks of the wind limit (:class:`masonry.mission.wind_limit.WindLimit`),
:class:`JournalPort` what it writes to a journal (:class:`masonry.mission.journal.Journal`, or the simulator's
:class:`masonry.mission.measured.MeasuredJournal`), and :class:`MissionHost` what the operator
(:class:`masonry.mission.operator.Operator`) asks of mission control: its UAVs, journal, events and recalls.
"""

from __future__ import annotations

from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from masonry.mission.records import UavLink

__all__ = ["Assignments", "JournalPort", "MissionHost", "WindGate"]


class JournalPort(Protocol):
    """The journal as mission control writes it: assignments, completions, failures, losses, metadata."""

    def record_assignment(self, time_s: float, task_id: str, uav: str, attempt: int) -> None: ...
    def record_completion(
        self, time_s: float, task_id: str, uav: str, *, attempt: int | None = None, **fields: object
    ) -> None: ...
    def record_failure(
        self, time_s: float, task_id: str, uav: str, reason: str, *, attempt: int | None = None
    ) -> None: ...
    def record_uav_lost(self, time_s: float, uav: str) -> None: ...
    def set_meta(self, key: str, value: object) -> None: ...


class Assignments(Protocol):
    """The dispatcher as the operator sees it: which UAV each task in progress is on."""

    @property
    def in_progress(self) -> Mapping[str, str]: ...


class MissionHost(Protocol):
    """Mission control as its operator sees it."""

    @property
    def journal(self) -> JournalPort | None: ...
    @property
    def ended_at_s(self) -> float | None: ...
    @property
    def uavs(self) -> Mapping[str, UavLink]: ...
    @property
    def dispatcher(self) -> Assignments: ...

    def wake(self) -> None:
        """Dispatch again at the next step."""

    def recall(
        self, uav: str, now_s: float, reason: str, task_id: str | None = None, attempt: int = 0
    ) -> None:
        """Tell ``uav`` to drop attempt ``attempt`` of ``task_id`` (None: whatever it holds), fly home and land."""

    def emit_event(
        self, now_s: float, kind: str, uav: str | None = None, task_id: str | None = None, **fields: object
    ) -> None:
        """Hand an event to the sink, if any."""


class WindGate(Protocol):
    """The wind limit as mission control sees it: who the wind grounds now."""

    @property
    def grounded(self) -> AbstractSet[str]: ...
    @property
    def speed_mps(self) -> float | None: ...
    @property
    def version(self) -> int: ...

    def update(self, now_s: float) -> bool:
        """Read the wind; True when the set of grounded UAVs changed."""

    def allows(self, name: str) -> bool:
        """``name`` may be given a task."""
