"""One MissionLink contract, run against the scripted fake (:class:`~masonry.fakes.QueueMissionLink`), the UAV
handler over the in-process bus (what ``masonry sim`` runs) and the UAV handler over Zenoh on loopback (what
``masonry fly --mission`` runs), mission control's side played by hand.

What every MissionLink must do: nothing to hand out is ``None``; a task given is handed out once and in the
order given (the next after the result of the previous); progress and results reach mission control.
"""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from contract_waits import wait_for
from masonry.blueprint import load_blueprint
from masonry.planner import plan
from masonry.planner.tasks import Task
from masonry.ports import MissionLink, TaskResult

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
UAV = "brick-1"


@dataclass
class Rig:
    link: MissionLink
    give: Callable[[Task], None]  # mission control assigns a task to the UAV
    heard: Callable[[], tuple[list[tuple[str, str]], list[tuple[str, str]]]]  # progress, results so far
    tick: Callable[[], None] = field(default=lambda: None)  # the UAV handler's loop turns once


def _fake() -> Iterator[Rig]:
    from masonry.fakes import QueueMissionLink

    link = QueueMissionLink()

    def heard() -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
        return [(t, s) for t, s, _ in link.progress], [(r.task_id, r.status) for r in link.results]

    yield Rig(link, link.push, heard)


def _handler(uav_end, mc_end) -> Iterator[Rig]:
    from masonry.mission.handler import UavHandler
    from masonry.mission.messages import MISSION_CONTROL, Assign, Progress, Result, decode, encode

    handler = UavHandler(UAV, uav_end)
    progress: list[tuple[str, str]] = []
    results: list[tuple[str, str]] = []
    attempts = {"n": 0}
    clock = {"now_s": 0.0}

    def give(task: Task) -> None:
        attempts["n"] += 1
        mc_end.send(UAV, encode(Assign(MISSION_CONTROL, UAV, task, attempts["n"], clock["now_s"])))

    def heard() -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
        for raw in mc_end.receive():
            msg = decode(raw, {UAV})
            if isinstance(msg, Progress):
                progress.append((msg.task_id, msg.state))
            elif isinstance(msg, Result):
                results.append((msg.result.task_id, msg.result.status))
        return list(progress), list(results)

    def tick() -> None:
        clock["now_s"] += 0.05
        handler.step(clock["now_s"])

    yield Rig(handler, give, heard, tick)


def _inproc() -> Iterator[Rig]:
    from masonry.mission.inproc import InprocBus
    from masonry.mission.messages import MISSION_CONTROL

    bus = InprocBus()
    yield from _handler(bus.endpoint(UAV), bus.endpoint(MISSION_CONTROL))


def _zenoh() -> Iterator[Rig]:
    from masonry.mission.messages import MISSION_CONTROL, Heartbeat, encode
    from masonry.mission.zenoh_transport import ZenohTransport

    def free_port() -> int:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            return int(s.getsockname()[1])

    port = free_port()
    with ExitStack() as stack:
        mc = stack.enter_context(
            ZenohTransport(MISSION_CONTROL, listen=[f"tcp/127.0.0.1:{port}"], mission="ml")
        )
        uav = stack.enter_context(
            ZenohTransport(
                UAV, listen=[f"tcp/127.0.0.1:{free_port()}"], connect=[f"tcp/127.0.0.1:{port}"], mission="ml"
            )
        )
        # both ways connected, then nothing left on the way (see test_contract_transport)
        for src, dst in ((uav, mc), (mc, uav)):
            ping, last = encode(Heartbeat(src.name, 0.0)), encode(Heartbeat(src.name, -1.0))
            wait_for(lambda s=src, d=dst, p=ping: (s.send(d.name, p), d.receive())[1], what="peers connect")
            src.send(dst.name, last)
            wait_for(lambda d=dst, m=last: m in d.receive(), what="pings drained")
        yield from _handler(uav, mc)


RIGS = {"fake": _fake, "handler-inproc": _inproc, "handler-zenoh": _zenoh}


@pytest.fixture(params=sorted(RIGS))
def rig(request) -> Iterator[Rig]:
    yield from RIGS[request.param]()


@pytest.fixture(scope="module")
def tasks() -> list[Task]:
    return [t for t in plan(load_blueprint(CASE_STUDY)).tasks if not t.done][:2]


def _poll(rig: Rig) -> Task:
    def once() -> Task | None:
        rig.tick()
        return rig.link.poll_task()

    return wait_for(once, what="a task handed out")


def test_nothing_given_is_none(rig: Rig) -> None:
    assert isinstance(rig.link, MissionLink)
    rig.tick()
    assert rig.link.poll_task() is None


def test_a_task_given_is_handed_out_once(rig: Rig, tasks: list[Task]) -> None:
    rig.give(tasks[0])
    assert _poll(rig).id == tasks[0].id
    rig.tick()
    assert rig.link.poll_task() is None


def test_tasks_come_in_order_and_progress_and_results_reach_mission_control(
    rig: Rig, tasks: list[Task]
) -> None:
    first, second = tasks
    rig.give(first)
    rig.give(second)
    assert _poll(rig).id == first.id
    rig.link.report_progress(first.id, "approach", 1.0)
    rig.link.report_result(TaskResult(first.id, "done", 12.5))
    assert _poll(rig).id == second.id
    rig.link.report_result(TaskResult(second.id, "failed", 3.0, reason="grasp failed"))

    def both_results() -> tuple[list[tuple[str, str]], list[tuple[str, str]]] | None:
        heard = rig.heard()
        return heard if len(heard[1]) >= 2 else None

    progress, results = wait_for(both_results, what="results heard")
    assert progress == [(first.id, "approach")]
    assert results == [(first.id, "done"), (second.id, "failed")]
