"""Mission control's parts on their own: the pure reducer (message -> steps, verdicts) and the liveness tracker."""

from __future__ import annotations

import pytest

from masonry.blueprint import UavSpec
from masonry.mission.journal_state import LOST_REASON
from masonry.mission.liveness import Lapse, Liveness, LivenessTracker, Timeouts, way_home_s
from masonry.mission.messages import ClearanceRequest, Heartbeat, Progress, Recall, Result
from masonry.mission.records import Attempt, UavLink
from masonry.mission.reducer import (
    OUT_OF_SERVICE_STATE,
    Ignored,
    Step,
    dropped_reason,
    late_completion,
    loss_reason,
    screen_result,
    steps_of,
    way_home_of,
)
from masonry.mission.uav_facts import UavFacts, facts_of
from masonry.ports import LAST_RESORT_S, TASK_DROPPED_REASON, TaskResult


def _result(status: str = "done", *, state: str = "", attempt: int = 1, sender: str = "b1") -> Result:
    r = TaskResult("B0", "done" if status == "done" else "failed", 10.0)
    return Result(sender, r, 50.0, state=state, attempt=attempt, out_of_service=state == OUT_OF_SERVICE_STATE)


def test_each_message_asks_for_its_steps_in_order() -> None:
    assert steps_of(_result()) == (Step.RESULT,)
    # out of service: a completion still counts, then the UAV leaves; a failure is not the task's fault
    assert steps_of(_result(state=OUT_OF_SERVICE_STATE)) == (Step.RESULT, Step.RETIRE)
    assert steps_of(_result("failed", state=OUT_OF_SERVICE_STATE)) == (Step.RETIRE,)
    assert steps_of(Heartbeat("b1", 1.0, state="idle")) == (Step.HEARTBEAT, Step.REPORT)
    assert steps_of(Progress("b1", "B0", "transit", 1.0)) == (Step.PROGRESS, Step.REPORT)
    assert steps_of(Heartbeat("b1", 1.0, state=OUT_OF_SERVICE_STATE, out_of_service=True)) == (Step.RETIRE,)
    assert steps_of(Progress("b1", "B0", "x", 1.0, out_of_service=True)) == (Step.RETIRE,)
    # the fact decides, not the state name
    assert steps_of(Heartbeat("b1", 1.0, state=OUT_OF_SERVICE_STATE)) == (Step.HEARTBEAT, Step.REPORT)
    no_fact = Result("b1", TaskResult("B0", "failed", 1.0), 50.0, state=OUT_OF_SERVICE_STATE, attempt=1)
    assert steps_of(no_fact) == (Step.RESULT,)
    assert steps_of(ClearanceRequest("b1", (0.0, 0.0, 1.0), 1.0)) == (Step.CLEARANCE,)
    assert steps_of(Recall("mission-control", "b1", 1.0, "recalled")) == ()


def test_a_result_is_acted_on_only_from_its_uav_for_its_attempt_and_not_too_soon() -> None:
    att = Attempt("B0", "b1", 2, start_s=40.0)
    ok = screen_result(_result(attempt=2), "b1", att, 20.0, 0.5, 50.0)
    assert ok is None
    for owner, running in (("b2", att), ("b1", None)):
        ignored = screen_result(_result(attempt=2), owner, running, None, 0.9, 50.0)
        assert ignored is not None and ignored.reason == "not-assigned"
    wrong = screen_result(_result(attempt=1), "b1", att, None, 0.9, 50.0)
    assert wrong is not None and wrong.reason == "wrong-attempt" and "the current one is 2" in wrong.detail
    short = screen_result(_result(attempt=2), "b1", att, 20.0, 0.9, 50.0)  # 10 s < 0.9 x 20 s
    assert short is not None and short.reason == "too-short"
    # a failure may come at any time, and an attempt kept from before a resume has no known start
    assert screen_result(_result("failed", attempt=2), "b1", att, 20.0, 0.9, 50.0) is None
    adopted = Attempt("B0", "b1", 2, start_s=49.0, adopted=True)
    assert screen_result(_result(attempt=2), "b1", adopted, 20.0, 0.9, 50.0) is None


@pytest.mark.parametrize(
    ("reason", "settled", "taken"),
    [
        (LOST_REASON, False, True),
        (f"{TASK_DROPPED_REASON} (its heartbeat holds no task)", False, True),
        (LOST_REASON, True, False),  # done (or stuck) since
        ("battery low", False, False),  # it failed the task itself
    ],
)
def test_a_completion_heard_late_counts_only_for_a_task_released_from_its_uav(
    reason: str, settled: bool, taken: bool
) -> None:
    named = Attempt("B0", "b1", 1, 0.0, 30.0, "failed", reason)
    assert late_completion(_result(), named, settled) is taken
    assert not late_completion(_result(attempt=2), named, settled)  # (not the attempt it names)
    assert not late_completion(_result("failed"), named, settled)
    assert not late_completion(_result(), None, settled)  # an attempt its UAV never had


def test_a_late_completion_is_told_from_a_later_assignment_of_the_task_to_the_same_uav() -> None:
    """Each assignment has its own number (issue 27, branch ``attempt43``): b1's first attempt, released when b1 was
    declared lost, completes after b1 was given the task again (attempt 2): that completion is the first one's,
    heard late, not the second's (before, both were attempt 1 and the completion was taken for the second)."""
    first = Attempt("B0", "b1", 1, 0.0, 30.0, "failed", LOST_REASON)
    second = Attempt("B0", "b1", 2, 40.0)
    assert late_completion(_result(), first, False)
    assert screen_result(_result(), "b1", second, 20.0, 0.9, 70.0) == Ignored(
        "wrong-attempt", "a result for B0 from b1 for attempt 1: the current one is 2"
    )


def test_an_idle_heartbeat_with_no_task_releases_an_assignment_older_than_the_timeout() -> None:
    idle = Heartbeat("b1", 20.0, state="idle", on_pad=True)
    att = Attempt("B0", "b1", 1, start_s=10.0)
    reason = dropped_reason(idle, att, 20.0, 5.0)
    assert reason is not None and reason.startswith(TASK_DROPPED_REASON) and "10.0 s" in reason
    assert dropped_reason(idle, att, 14.0, 5.0) is None  # the assignment may still be on its way
    assert dropped_reason(Heartbeat("b1", 20.0, state="transit"), att, 20.0, 5.0) is None  # busy flying
    assert (
        dropped_reason(Heartbeat("b1", 20.0, state="idle", on_pad=True, task_id="B0"), att, 20.0, 5.0) is None
    )
    # mission control reads the fact, not the state name: "idle" without on_pad is not down on the pad
    assert dropped_reason(Heartbeat("b1", 20.0, state="idle"), att, 20.0, 5.0) is None
    assert dropped_reason(Heartbeat("b1", 20.0, state="parked", on_pad=True), att, 20.0, 5.0) is not None
    adopted = Attempt("B0", "b1", 1, start_s=19.0, adopted=True)
    assert "after the resume" in (dropped_reason(idle, adopted, 20.0, 5.0) or "")


def test_the_way_home_and_the_loss_reason_follow_what_the_uav_last_said() -> None:
    via = (1.0, 2.0, 0.5)
    # the facts the UAV side reads off its machine (masonry.mission.uav_facts.facts_of) ...
    assert way_home_of(facts_of("home"), via, 3.3) == (3.3, None)
    assert way_home_of(facts_of("putback_goto"), via, None) == (None, via)
    assert way_home_of(facts_of("putback_release"), via, 3.3) == (3.3, None)
    assert way_home_of(facts_of("idle"), via, 3.3) is None
    # ... and mission control decides from the facts alone, whatever the state is called
    assert way_home_of(UavFacts(flying_home=True, carrying=True), via, 3.3) == (3.3, via)
    assert way_home_of(UavFacts(carrying=True), via, 3.3) is None
    assert loss_reason(None, "transit", None) == LOST_REASON
    assert (
        loss_reason(None, "transit", 7)
        == f"{LOST_REASON} (last heard in transit, with brick 7 on its magnet)"
    )
    assert loss_reason("out of service", "halted", 7) == "uav out of service"


def _tracker() -> tuple[LivenessTracker, dict[str, UavLink]]:
    links = {
        "b1": UavLink(UavSpec("b1", "brick", (0.0, 0.0, 0.0))),
        "a1": UavLink(UavSpec("a1", "adhesion", (2.0, 0.0, 0.0))),
    }
    return LivenessTracker(links, Timeouts(heartbeat_s=5.0, rejoin_s=30.0)), links


def test_liveness_moves_through_one_enum() -> None:
    live, links = _tracker()
    b1 = links["b1"]
    assert b1.liveness is Liveness.SILENT and b1.status == "ok" and not b1.lost
    assert live.never_heard() == ["b1", "a1"] and live.online() == []
    live.heard(b1, 0.0)
    assert b1.liveness is Liveness.HEARD and live.online() == ["b1"]
    assert live.sweep(5.0, lambda _n: False) == []
    assert live.sweep(5.5, lambda _n: False) == [("b1", Lapse.SILENT_TOO_LONG)]
    live.lose(b1, 5.5)
    assert b1.liveness is Liveness.LOST and b1.lost and b1.status == "lost" and b1.lost_at_s == 5.5
    assert live.sweep(100.0, lambda _n: False) == []  # lost: not swept again
    live.rejoin(b1)
    assert b1.liveness is Liveness.REJOINED and b1.status == "ok" and b1.lost_at_s is None
    live.lose(b1, 200.0, out_of_service=True)
    assert b1.liveness is Liveness.OUT_OF_SERVICE and b1.status == "out of service" and b1.lost


def test_a_uav_finishing_its_work_is_silent_for_the_rejoin_timeout_before_it_is_lost() -> None:
    live, links = _tracker()
    b1 = links["b1"]
    live.heard(b1, 0.0)
    b1.state, b1.facts = "place_descend", facts_of("place_descend")
    assert b1.facts.finishing
    assert live.sweep(20.0, lambda _n: True) == []
    assert b1.liveness is Liveness.SILENT and not b1.lost  # in its grace
    live.heard(b1, 21.0)
    assert b1.liveness is Liveness.HEARD
    assert live.sweep(27.0, lambda _n: False) == [("b1", Lapse.SILENT_TOO_LONG)]  # no task: 5 s
    assert live.sweep(56.0, lambda _n: True) == []  # with its task: 5 + 30 s
    assert live.sweep(56.5, lambda _n: True) == [("b1", Lapse.SILENT_TOO_LONG)]


def test_the_grace_follows_the_finishing_fact_not_the_state_name() -> None:
    live, links = _tracker()
    b1 = links["b1"]
    live.heard(b1, 0.0)
    b1.state, b1.facts = "place_descend", UavFacts()  # a familiar name, but it does not say it is finishing
    assert live.sweep(5.5, lambda _n: True) == [("b1", Lapse.SILENT_TOO_LONG)]
    live.heard(b1, 10.0)
    b1.state, b1.facts = "a-new-state", UavFacts(finishing=True)  # an unfamiliar name that says it is
    assert live.sweep(40.0, lambda _n: True) == []


def test_a_lost_uavs_way_home_is_freed_when_its_time_is_up() -> None:
    live, links = _tracker()
    b1 = links["b1"]
    live.heard(b1, 0.0)
    live.lose(b1, 6.0)
    b1.airspace_until_s = 50.0
    assert live.sweep(49.0, lambda _n: False) == []
    assert live.sweep(50.0, lambda _n: False) == [("b1", Lapse.AIRSPACE_EXPIRED)]
    assert b1.airspace_until_s is None
    assert way_home_s(10.0, 2.0) == pytest.approx(LAST_RESORT_S + 5.0 + 30.0)


def test_a_mission_waits_for_a_role_whose_last_uav_fell_silent() -> None:
    live, links = _tracker()
    for link in links.values():
        live.heard(link, 0.0)
    live.lose(links["a1"], 10.0)
    assert live.awaiting_rejoin(39.0) and not live.awaiting_rejoin(41.0)
    live.lose(links["b1"], 10.0, out_of_service=True)  # out of service: never awaited
    assert live.awaiting_rejoin(39.0)  # (the adhesion UAV still is)
    live.rejoin(links["a1"])
    assert not live.awaiting_rejoin(11.0)
