"""The UAV machines' watchdogs (masonry.fsm.watchdogs): pure checks declared beside the states they guard."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest
from typer.testing import CliRunner

from fsm_rig import Rig
from masonry.cli import app
from masonry.fsm import UavConfig
from masonry.fsm.diagram import machine_graph, watchdog_lines
from masonry.fsm.fence import FenceWatch
from masonry.fsm.watchdogs import (
    ADHESION_WATCHDOGS,
    BRICK_WATCHDOGS,
    TASK,
    Abort,
    Failsafe,
    Watchdog,
    fence_watch,
    hold_watch,
    link_watch,
)
from masonry.geofence import Site
from masonry.ports import Telemetry

BRICK_TASK_LEAVES = frozenset({"takeoff", "pickup_goto", "pickup_align", "transport", "place_descend"})


# -- a newcomer's watchdog: one declaration -----------------------------------------------------------------
def marker_lost(now_s: float, tel: Telemetry, attempt: Any) -> Abort | None:
    """The camera has seen no marker in 20 s of looking for the brick: give the task up."""
    looked_s = attempt.phase_clock.so_far().estimating
    if attempt.attempt.estimates_seen == 0 and looked_s > 20.0:
        return Abort(f"the camera has seen no marker in {looked_s:.0f} s of looking for the brick")
    return None


MARKER_LOST = Watchdog("marker_lost", ("pickup_estimate",), marker_lost)


def test_a_declared_watchdog_aborts_the_task_with_its_reason() -> None:
    rig = Rig("brick", camera={"blind": True})
    rig.uav.watchdogs = (*rig.uav.watchdogs, MARKER_LOST)
    rig.run()
    (result,) = rig.link.results
    assert result.status == "failed"
    assert result.reason is not None and result.reason.startswith("the camera has seen no marker in 20 s")
    assert (
        result.phases is not None
        and 20.0 < result.phases.estimating <= 20.0 + 2 * rig.config.control_period_s
    )
    # the machine's own reaction to an abort: the failsafe, home, landed
    assert rig.followed("pickup_estimate", "failsafe")
    assert rig.states[-4:] == ["failsafe", "home", "land", "idle"]


def test_without_the_watchdog_the_machine_gives_up_on_its_own_terms() -> None:
    rig = Rig("brick", camera={"blind": True}).run()
    (result,) = rig.link.results
    assert "not seen near its pickup" in (result.reason or "")
    assert result.phases is not None and result.phases.estimating > 21.0  # it looked longer than the watchdog


def test_the_defaults_are_the_standard_list_in_order() -> None:
    assert [d.name for d in Rig("brick").uav.watchdogs] == ["link", "battery", "hold", "fence", "autopilot"]
    assert Rig("brick").uav.watchdogs == BRICK_WATCHDOGS
    assert Rig("adhesion").uav.watchdogs == ADHESION_WATCHDOGS


# -- the declared states ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("states", "leaf", "guarded"),
    [
        (("pickup",), "pickup_align", True),  # a parent guards its children
        (("pickup_estimate",), "pickup_align", False),
        (("*",), "land", True),
        ((TASK,), "pickup_goto", True),
        ((TASK,), "putback_goto", False),
        ((TASK,), "home", False),
    ],
)
def test_a_watchdog_guards_the_states_it_names(states, leaf, guarded) -> None:
    assert Watchdog("w", states, link_watch).guards(leaf, BRICK_TASK_LEAVES) is guarded


def test_the_brick_fence_guards_every_airborne_state_but_the_landing_and_emergency() -> None:
    (fence,) = [d for d in BRICK_WATCHDOGS if d.name == "fence"]
    leaves = ["takeoff", "pickup_goto", "putback_release", "home", "failsafe"]
    assert all(fence.guards(s, BRICK_TASK_LEAVES) for s in leaves)
    assert not any(fence.guards(s, BRICK_TASK_LEAVES) for s in ["idle", "land", "emergency", "halted"])


# -- the checks are pure: they read and return, the model acts --------------------------------------------
def _tel(**kw: Any) -> Telemetry:
    base: dict[str, Any] = {
        "time_s": 0.0,
        "position_m": (0.0, 0.0, 2.0),
        "velocity_mps": (0.0, 0.0, 0.0),
        "attitude_rad": (0.0, 0.0, 0.0),
        "armed": True,
        "mode": "GUIDED",
        "battery_fraction": 0.9,
        "link_ok": True,
        "position_ok": True,
        "on_ground": False,
    }
    base.update(kw)
    return Telemetry(**base)


def _attempt(**kw: Any) -> SimpleNamespace:
    base: dict[str, Any] = {
        "state": "pickup_goto",
        "task": object(),
        "config": UavConfig("b", "brick", (0.0, 0.0, 0.0), hold_patience_s=60.0),
        "failsafe": Failsafe(),
        "held_since_s": None,
        "fence_watch": None,
        "task_states": BRICK_TASK_LEAVES,
        "site_text": lambda: "(1.00, 2.00, 3.00)",
    }
    base.update(kw)
    return SimpleNamespace(**base)


def test_link_watch_reactions_per_state() -> None:
    down = _tel(link_ok=False)
    timeout_s = _attempt().config.link_lost_timeout_s
    assert link_watch(5.0, _tel(), _attempt(failsafe=Failsafe(link_down_since_s=None))) is None
    flying = _attempt(failsafe=Failsafe(link_down_since_s=5.0))
    assert link_watch(5.0, down, flying) == Abort("flight controller link lost", "land")
    idle = _attempt(state="idle", failsafe=Failsafe(link_down_since_s=0.0))
    assert link_watch(timeout_s, down, idle) is None
    assert link_watch(timeout_s + 0.1, down, idle) == Abort("flight controller link lost", "retire")
    emergency = _attempt(state="emergency", failsafe=Failsafe(link_down_since_s=0.0))
    assert link_watch(1.0, down, emergency) is None
    landed = _tel(link_ok=False, on_ground=True)
    assert link_watch(1.0, landed, emergency) == Abort("flight controller link lost", "give_up")


def test_hold_watch_past_the_patience() -> None:
    a = _attempt(held_since_s=10.0)
    assert hold_watch(70.0, _tel(), a) is None
    verdict = hold_watch(70.5, _tel(), a)
    assert verdict == Abort(
        "held 60 s for clearance to (1.00, 2.00, 3.00), longer than hold_patience_s", "abort"
    )


def test_fence_watch_gives_the_task_up_then_lands_where_it_is() -> None:
    watch = FenceWatch(Site(((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)), 5.0))
    out = _tel(position_m=(3.0, 0.0, 2.0))
    assert watch.observe(0.0, out.position_m)
    verdict = fence_watch(0.0, out, _attempt(fence_watch=watch))
    assert (
        verdict is not None
        and verdict.action == "abort"
        and "outside the site fence by 2.00 m" in verdict.reason
    )
    home = _attempt(state="home", task=None, fence_watch=watch)
    return_s = home.config.fence_return_s
    assert fence_watch(return_s, out, home) is None
    verdict = fence_watch(return_s + 0.1, out, home)
    assert verdict is not None and verdict.action == "land" and verdict.reason.endswith("landing where it is")
    assert fence_watch(return_s + 0.1, _tel(position_m=(3.0, 0.0, 0.0), on_ground=True), home) is None


# -- masonry fsm diagram draws them -------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["brick", "adhesion"])
def test_the_diagram_names_each_watchdog_and_its_states(kind, tmp_path, monkeypatch) -> None:
    from masonry.fsm import diagram

    lines = watchdog_lines(kind)
    assert "watchdog battery: takeoff" in lines[2]
    source = machine_graph(kind).source
    for name in ("link", "battery", "hold", "fence"):
        assert f"watchdog {name}: " in source
    monkeypatch.setattr(diagram.shutil, "which", lambda name: None)  # the built-in layout
    out = tmp_path / f"{kind}.svg"
    res = CliRunner().invoke(app, ["fsm", "diagram", kind, "-o", str(out)])
    assert res.exit_code == 0, res.output
    svg = out.read_text()
    for line in lines[1:]:
        assert line in svg
