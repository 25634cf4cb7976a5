"""What the simulated world measured, beside what mission control knows: into the journal and the report.

:class:`MeasuredJournal` adds the world's measurements to every record mission control journals (so that a
resumed report says what the run that did the work would have said); :func:`simulated_report` builds the
mission's report with the safety checks measured independently of mission control (the intervals the UAV
handlers executed, the separation of the world's vehicles).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from masonry.blueprint import Blueprint, UavSpec
from masonry.errors import ProtocolError
from masonry.mission.control import MissionControl
from masonry.mission.envelope import EnvelopeExcursion, EnvelopeWatch, worse
from masonry.mission.handler import UavHandler
from masonry.mission.messages import Result, decode
from masonry.mission.report import MissionReport, control_report
from masonry.mission.spares import SpareBook
from masonry.planner.bounds import min_cycles_s, min_durations_s, min_site_s
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan
from masonry.timing import DEFAULT_TIMING, TaskTiming


class MeasuredJournal:
    """The journal as mission control sees it, with what the world measured added to every record.

    Each record carries ``measured``: the distance each UAV has flown, its busy time (the tasks its handler
    executed) and the minimum separation so far (over the whole mission: a resumed run adds the values the
    journal had), a brick's completion its true placement error, and with an adhesive the glue's times, ages and
    violations (``glue``). A resumed report takes them from the
    journal (:func:`simulated_report`) instead of the UAVs' own estimates or a rebuilt world that has flown nothing yet.
    """

    def __init__(
        self,
        journal: Any,
        world: Any,
        plan: Plan,
        before: Mapping[str, Any],
        kept: Mapping[str, KeptCompletion] | None = None,
        before_meta: Mapping[str, object] | None = None,
        at_place_m: float | None = None,
    ) -> None:
        self.journal = journal
        #: UAV -> the completion it kept before the stop this run resumes from (:func:`kept_completions`)
        self.before_kept = dict(kept or {})
        self.world = world
        self._bricks = {t.id: t.brick for t in plan.tasks if isinstance(t, BrickTask)}
        self._beads = {t.id: (t.start_m, t.end_m) for t in plan.tasks if isinstance(t, AdhesionTask)}
        self.before_distances_m = _floats(before.get("distances_m"))
        self.before_busy_s = _floats(before.get("busy_s"))
        sep = before.get("min_separation_m")
        self.before_min_separation_m = float(sep) if isinstance(sep, (int, float)) else None
        was = before.get("envelope_excursion")
        self.before_envelope = None if was is None else EnvelopeExcursion.from_dict(was)
        #: the UAVs against their reserved envelopes (set by the mission; None: no airspace rules, no watch)
        self.envelope: EnvelopeWatch | None = None
        # a rebuilt world lays the glue laid before the stop again, and goes on counting (masonry.sim.glue)
        world.glue.restore(before.get("glue"))
        self.handlers: Mapping[str, UavHandler] = {}  # set once the handlers exist
        self.dead: Mapping[str, float] = {}  # UAV -> the time it failed (it flies no more)
        self.spares: SpareBook | None = None  # mission control's, once it exists: which spare stands in where
        #: brick id -> placement error of the bricks the world held at their places before the stop this run
        #: resumes from (:data:`WALL_META_KEY`): rebuilt in place, their errors the ones measured then
        self.before_on_wall = on_wall_of(before_meta)
        self._releases_seen = 0  # the world's releases already looked at (:meth:`note_wall`)
        #: a brick released this close to its design centre is at its place (None: the wall is not kept)
        self.at_place_m = at_place_m

    def error_m(self, task_id: str) -> float | None:
        """The world's true placement error of a brick task's brick, or of the spare standing in for it
        (its distance from the brick's design centre; None: not released, or not on the wall)."""
        if self._bricks[task_id] in self.before_on_wall:
            return self.before_on_wall[self._bricks[task_id]]  # (placed before the stop: measured then)
        use = self.spares.spare_of(task_id) if self.spares is not None else None
        if use is None:
            err = self.world.placement_error_m(self._bricks[task_id])
            return None if err is None else float(err)
        b = self.world.bricks.get(use.spare)
        if b is None or not b.released or b.state != "placed":
            return None
        return math.dist(b.position_m, self.world.blueprint.brick(use.brick).position_m)

    def distances_m(self) -> dict[str, float]:
        return {
            n: self.before_distances_m.get(n, 0.0) + float(self.world.distance_flown_m(n))
            for n in self.world.uavs
        }

    def busy_s(self) -> dict[str, float]:
        """Time each UAV spent on tasks, as its handler executed them (a running task counts until now)."""
        now = self.world.clock.now_s()
        out = dict(self.before_busy_s)
        for name, h in self.handlers.items():
            end_open = self.dead.get(name, now)
            out[name] = out.get(name, 0.0) + sum(
                (e.end_s if e.end_s is not None else end_open) - e.start_s for e in h.executions
            )
        return out

    def min_separation_m(self) -> float | None:
        seps = [
            s
            for s in (self.before_min_separation_m, self.world.min_separation_m)
            if s is not None and math.isfinite(s)
        ]
        return float(min(seps)) if seps else None

    def envelope_excursion(self) -> EnvelopeExcursion | None:
        """The worst envelope excursion of the whole mission (a resumed one: with the run's before the stop)."""
        now = None if self.envelope is None else self.envelope.worst(self.world.clock.now_s())
        return worse(self.before_envelope, now)

    def measurements(self, task_id: str | None = None) -> dict[str, Any]:
        """What the world measured so far (and, for a brick task, its true placement error)."""
        out: dict[str, Any] = {
            "distances_m": self.distances_m(),
            "busy_s": self.busy_s(),
            "min_separation_m": self.min_separation_m(),
        }
        envelope = self.envelope_excursion()
        if envelope is not None:
            out["envelope_excursion"] = envelope.to_dict()
        if self.world.glue.enabled:  # (an adhesive: its beads' times, ages and violations so far)
            if task_id in self._beads:
                self.world.glue.note_bead(*self._beads[task_id])
            out["glue"] = self.world.glue.snapshot()
        kept = next((k for k in self.before_kept.values() if k.task_id == task_id), None)
        if kept is not None and kept.placement_error_m is not None:
            out["placement_error_m"] = kept.placement_error_m  # placed before the stop: measured then
        elif task_id in self._bricks:
            err = self.error_m(task_id)
            if err is not None:
                out["placement_error_m"] = float(err)
        return out

    def note_wall(self) -> None:
        """After the world's step: if a brick was released since the last call, keep in the journal file's meta
        table (:data:`WALL_META_KEY`) the bricks the world holds at their places (within ``at_place_m`` of their
        design centres: the simulator gives ``masonry.sim.glue.AT_PLACE_M``), with their errors. A stop rebuilds
        the world, and they are on the wall whatever mission control knew of them (a UAV that released its brick
        and fell, or was cut by the stop, before it reported done)."""
        if self.journal is None or self.at_place_m is None or len(self.world.releases) == self._releases_seen:
            return
        self._releases_seen = len(self.world.releases)
        on_wall = dict(self.before_on_wall)
        for task_id, brick_id in self._bricks.items():
            if brick_id not in on_wall and self._released(task_id):
                err = self.error_m(task_id)
                if err is not None and err <= self.at_place_m:
                    on_wall[brick_id] = err
        self.journal.set_meta(WALL_META_KEY, {str(b): e for b, e in sorted(on_wall.items())})

    def _released(self, task_id: str) -> bool:
        """Whether the brick of ``task_id`` (or the spare standing in for it) was released by a UAV in this world."""
        use = self.spares.spare_of(task_id) if self.spares is not None else None
        b = self.world.bricks.get(self._bricks[task_id] if use is None else use.spare)
        return b is not None and b.released and b.state == "placed"

    # -- the UAVs' kept completions (masonry.mission.handler.ResultKeeper) ------------------------------------
    def kept(self, uav: str) -> bytes | None:
        """The completion ``uav`` kept in the journal file before a stop, unheard by mission control."""
        entry = self.before_kept.get(uav)
        return entry.message if entry is not None else None

    def keep(self, uav: str, message: bytes | None) -> None:
        """Keep ``uav``'s unheard completion in the journal file's meta table (``unheard/<uav>``), with the
        world's true placement error of its brick: a stop rebuilds the world, and the brick is on the wall."""
        if self.journal is None:
            return
        if message is None:
            self.journal.set_meta(KEPT_META_PREFIX + uav, None)
            return
        value: dict[str, Any] = {"message": message.decode("utf-8")}
        task_id = _task_of(message)
        if task_id in self._bricks:
            err = self.error_m(task_id)
            if err is not None:
                value["placement_error_m"] = float(err)
        self.journal.set_meta(KEPT_META_PREFIX + uav, value)

    def record_assignment(self, time_s: float, task_id: str, uav: str, attempt: int) -> None:
        self.journal.record_assignment(time_s, task_id, uav, attempt, measured=self.measurements())

    def record_completion(
        self, time_s: float, task_id: str, uav: str, *, attempt: int | None = None, **fields: Any
    ) -> None:
        self.journal.record_completion(
            time_s, task_id, uav, attempt=attempt, **fields, measured=self.measurements(task_id)
        )

    def record_failure(
        self, time_s: float, task_id: str, uav: str, reason: str, *, attempt: int | None = None
    ) -> None:
        self.journal.record_failure(
            time_s, task_id, uav, reason, attempt=attempt, measured=self.measurements()
        )

    def record_uav_lost(self, time_s: float, uav: str) -> None:
        self.journal.record_uav_lost(time_s, uav, measured=self.measurements())

    def __getattr__(self, name: str) -> Any:
        return getattr(self.journal, name)  # anything else mission control asks of the journal


#: The simulator's journal meta key of the bricks its world held at their places (brick id -> placement error, m):
#: a world rebuilt after a stop has them in place (:func:`masonry.mission.sim_resume.resumed_world`). Mission
#: control neither writes nor reads it; a journal without it (a real mission's, an older one) rebuilds none.
WALL_META_KEY = "world/on_wall"


def on_wall_of(meta: Mapping[str, object] | None) -> dict[int, float]:
    """The bricks :data:`WALL_META_KEY` says the world held at their places (anything unreadable is ignored)."""
    value = meta.get(WALL_META_KEY) if meta is not None else None
    items = value.items() if isinstance(value, Mapping) else ()
    return {
        int(k): float(v)
        for k, v in items
        if str(k).isdigit() and isinstance(v, (int, float)) and math.isfinite(v)
    }


#: Journal meta keys of the UAVs' kept completions: ``unheard/<uav>`` -> {message, placement_error_m} or null.
KEPT_META_PREFIX = "unheard/"


@dataclass(frozen=True)
class KeptCompletion:
    """A completion a UAV kept before a stop, unheard by mission control: its wire form, its task, and the
    world's true placement error of its brick (None: an adhesion task, or not measured)."""

    uav: str
    task_id: str
    time_s: float  # when the UAV finished (a resumed mission's clock starts no earlier)
    message: bytes
    placement_error_m: float | None = None


def kept_completions(state: Any) -> dict[str, KeptCompletion]:
    """The completions the UAVs kept in a journal's meta table (anything unreadable in it is ignored)."""
    out: dict[str, KeptCompletion] = {}
    for key, value in state.meta.items() if state is not None else ():
        if not key.startswith(KEPT_META_PREFIX) or not isinstance(value, Mapping):
            continue
        text, err = value.get("message"), value.get("placement_error_m")
        msg = _result_of(text.encode("utf-8")) if isinstance(text, str) else None
        if msg is None or not isinstance(text, str):
            continue
        uav = key[len(KEPT_META_PREFIX) :]
        error_m = float(err) if isinstance(err, (int, float)) and math.isfinite(err) else None
        out[uav] = KeptCompletion(uav, msg.result.task_id, float(msg.time_s), text.encode("utf-8"), error_m)
    return out


def _result_of(message: bytes) -> Result | None:
    """A kept completion, read (None: not a readable result)."""
    try:
        msg = decode(message)
    except ProtocolError:
        return None
    return msg if isinstance(msg, Result) else None


def _task_of(message: bytes) -> str | None:
    """The task a kept completion names (None: not a readable result)."""
    msg = _result_of(message)
    return msg.result.task_id if msg is not None else None


def _floats(value: Any) -> dict[str, float]:
    """A journaled name -> number mapping (anything else in it is ignored)."""
    items = value.items() if isinstance(value, Mapping) else ()
    return {str(k): float(v) for k, v in items if isinstance(v, (int, float)) and math.isfinite(v)}


def kept_errors_m(kept: Mapping[str, KeptCompletion]) -> dict[str, float]:
    """Placement errors of the completions the UAVs kept unheard before a stop (measured then)."""
    return {k.task_id: k.placement_error_m for k in kept.values() if k.placement_error_m is not None}


def journaled_errors_m(state: Any) -> dict[str, float]:
    """Placement errors of the bricks done before a resume: the world's true one when the journal has it."""
    out: dict[str, float] = {}
    for rec in state.done if state is not None else ():
        m = rec.fields.get("measured")
        err = m.get("placement_error_m") if isinstance(m, Mapping) else None
        if err is None:
            err = rec.fields.get("placement_error_m")  # a journal without measurements: the UAV's estimate
        if isinstance(err, (int, float)):
            out[rec.task_id] = float(err)
    return out


def simulated_report(
    blueprint: Blueprint,
    the_plan: Plan,
    fleet: tuple[UavSpec, ...],
    mc: MissionControl,
    handlers: Mapping[str, UavHandler],
    world: Any,
    dead: Mapping[str, float],
    *,
    policy: str,
    seed: int,
    sim_time_s: float,
    wall_time_s: float,
    resumed_from: float | None,
    messages: int,
    measured: MeasuredJournal,
    journaled_errors_m: Mapping[str, float],
    timing: TaskTiming = DEFAULT_TIMING,
    cp_sat_bound_s: float | None = None,
    cpu_time_s: float = 0.0,
) -> MissionReport:
    now = world.clock.now_s()
    # Independent checks from what the UAVs executed (their handlers' traces; a UAV that failed stopped
    # flying when it failed), plus the completed attempts of the run before a resume (from the journal).
    intervals: list[tuple[str, str, float, float | None]] = []
    for name, h in handlers.items():
        for e in h.executions:
            intervals.append((name, e.task_id, e.start_s, e.end_s if e.end_s is not None else dead.get(name)))
    if resumed_from is not None:
        # the attempts the journal holds (done and failed) were flown before the resume: they count as then
        intervals.extend(
            (a.uav, a.task_id, a.start_s, a.end_s)
            for a in mc.history
            if a.end_s is not None and a.end_s <= resumed_from and a.status in ("done", "failed")
        )
    done = {a.task_id for a in mc.history if a.status == "done"}
    placement: dict[str, float] = {}
    for t in the_plan.tasks:
        if isinstance(t, BrickTask) and t.id in done:
            # a brick placed before the resume was rebuilt in place: its error is the one measured then
            err = journaled_errors_m[t.id] if t.id in journaled_errors_m else measured.error_m(t.id)
            if err is not None:
                placement[t.id] = float(err)
    minimum_s = min_durations_s(the_plan, cruise_altitude_m=blueprint.cruise_altitude_m, timing=timing)
    sep = measured.min_separation_m()
    distances = measured.distances_m()
    return control_report(
        mc,
        the_plan,
        policy=policy,
        seed=seed,
        intervals=intervals,
        busy_s=measured.busy_s(),
        distances_m={u.name: distances.get(u.name, 0.0) for u in fleet},
        placement_error_m=placement,
        min_separation_m=sep,
        envelope_excursion=measured.envelope_excursion(),
        now_s=now,
        durations_s=minimum_s,
        work_s=min_cycles_s(the_plan, fleet, minimum_s, timing=timing),
        clique_weights_s=(
            min_site_s(the_plan, cruise_altitude_m=blueprint.cruise_altitude_m, timing=timing)
            if mc.reservation == "site"
            else None
        ),
        cp_sat_bound_s=cp_sat_bound_s,
        paths_m={n: u.path_m()[:, 1:4] for n, u in world.uavs.items()},
        sim_time_s=sim_time_s,
        wall_time_s=wall_time_s,
        cpu_time_s=cpu_time_s,
        messages=messages,
        **(
            world.glue.report_fields({t.brick: t.id for t in the_plan.tasks if isinstance(t, BrickTask)})
            if world.glue.enabled
            else {}
        ),
    )


__all__ = [
    "KEPT_META_PREFIX",
    "WALL_META_KEY",
    "KeptCompletion",
    "MeasuredJournal",
    "journaled_errors_m",
    "kept_completions",
    "on_wall_of",
    "simulated_report",
]
