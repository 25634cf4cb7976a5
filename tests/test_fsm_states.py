"""The machines as data: well-formed, every callback exists, and every declared transition does what it says."""

from __future__ import annotations

import copy
import inspect
from typing import Any

import numpy as np
import pytest

from fsm_rig import Rig, brick_task
from masonry.fsm import AdhesionUav, BrickUav, UavModel
from masonry.fsm.states import MACHINES, leaf_states, triggers


def _all_states(states: list[dict[str, Any]], prefix: str = "") -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    for s in states:
        name = prefix + s["name"]
        out[name] = s
        out.update(_all_states(s.get("children", []), name + "_"))
    return out


def _leaves_under(name: str, leaves: list[str]) -> list[str]:
    return [leaf for leaf in leaves if leaf == name or leaf.startswith(name + "_")]


def _entry_leaf(name: str, states: dict[str, dict[str, Any]]) -> str:
    while states[name].get("children"):
        name = f"{name}_{states[name]['initial']}"
    return name


MODEL = {"brick": BrickUav, "adhesion": AdhesionUav}


@pytest.mark.parametrize("kind", sorted(MACHINES))
def test_state_names_have_no_separator_and_callbacks_exist(kind: str) -> None:
    states, transitions = MACHINES[kind]
    model_cls = MODEL[kind]
    for full, spec in _all_states(states).items():
        assert "_" not in spec["name"], f"state {spec['name']!r}: '_' is the nesting separator"
        if "on_enter" in spec:
            assert callable(getattr(model_cls, spec["on_enter"], None)), spec["on_enter"]
        if not spec.get("children"):
            assert callable(getattr(model_cls, "do_" + full, None)), f"no tick handler do_{full}"
        else:
            assert spec["initial"] in [c["name"] for c in spec["children"]]
    names = set(_all_states(states))
    for t in transitions:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        assert all(s in names for s in sources), t
        assert t["dest"] == "=" or t["dest"] in names, t
        for key in ("conditions", "before"):
            if key in t:
                assert callable(getattr(model_cls, t[key], None)), t[key]


@pytest.mark.parametrize("kind", sorted(MACHINES))
def test_triggers_are_declared_on_the_model_for_type_checkers(kind: str) -> None:
    _, transitions = MACHINES[kind]
    model_cls = MODEL[kind]
    annotations: dict[str, Any] = {}
    for cls in reversed(model_cls.__mro__):
        annotations.update(inspect.get_annotations(cls))
    missing = [t for t in triggers(transitions) if t not in annotations]
    assert missing == []


@pytest.mark.parametrize("kind", sorted(MACHINES))
def test_every_leaf_is_reachable_from_idle(kind: str) -> None:
    states, transitions = MACHINES[kind]
    tree = _all_states(states)
    leaves = leaf_states(states)
    edges: dict[str, set[str]] = {leaf: set() for leaf in leaves}
    for t in transitions:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        for src in sources:
            for leaf in _leaves_under(src, leaves):
                edges[leaf].add(leaf if t["dest"] == "=" else _entry_leaf(t["dest"], tree))
    seen, stack = {"idle"}, ["idle"]
    while stack:
        for nxt in edges[stack.pop()]:
            if nxt not in seen:
                seen.add(nxt)
                stack.append(nxt)
    assert seen == set(leaves)


def _airborne_rig(kind: str) -> Rig:
    """A rig whose UAV hovers at cruise altitude over its home with its task in hand."""
    rig = Rig(kind)
    rig.fc.arm()
    rig.fc.takeoff(1.2)
    rig.clock.advance(6.0)
    uav: UavModel = rig.uav
    uav._now_s = rig.clock.now_s()
    uav._tel = rig.fc.telemetry()
    task = rig.link.poll_task()
    assert task is not None
    uav._start_task(task)
    if isinstance(uav, BrickUav):
        uav.attempt.brick_estimate = (np.array(rig.brick.top_center_m), 0.6)
        uav.attempt.hover_z = 1.2
    return rig


def _cases() -> list[tuple[str, int, str]]:
    cases = []
    for kind, (states, transitions) in sorted(MACHINES.items()):
        leaves = leaf_states(states)
        for i, t in enumerate(transitions):
            sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
            for src in sources:
                for leaf in _leaves_under(src, leaves):
                    cases.append((kind, i, leaf))
    return cases


@pytest.mark.parametrize(("kind", "index", "source"), _cases())
def test_every_declared_transition(kind: str, index: int, source: str) -> None:
    states, transitions = MACHINES[kind]
    t = transitions[index]
    tree = _all_states(states)
    rig = _airborne_rig(kind)
    uav = rig.uav
    uav.machine.set_state(source)
    # Make this transition's condition hold, and the conditions of earlier ones with the same trigger fail.
    uav._next_task = brick_task("B9") if t.get("conditions") == "has_next_task" else None
    uav._halt_after_landing = "test" if t.get("conditions") == "must_halt" else None
    if isinstance(uav, BrickUav) and t["trigger"] == "abort":  # the brick on the magnet: it is put back first
        if t.get("conditions") == "may_put_back":
            uav.gripper.is_attached = lambda: True  # type: ignore[method-assign]
        else:
            uav.attempt.brick_estimate = None  # no pickup pose to put it back at
    n_results = len(rig.link.results)
    getattr(uav, t["trigger"])(reason="scripted")
    expected = source if t["dest"] == "=" else _entry_leaf(t["dest"], tree)
    assert uav.state == expected
    assert uav.trace[-1][1] == expected
    if t.get("before") == "fail_task":
        assert rig.link.results[n_results].status == "failed"
        assert rig.link.results[n_results].reason == "scripted"
    # The new state's tick runs without error.
    rig.clock.advance(0.1)
    uav.step(rig.clock.now_s())
    assert uav._last_step_s == rig.clock.now_s()


def test_machines_are_built_from_copies_of_the_data() -> None:
    before = copy.deepcopy(MACHINES)
    Rig("brick")
    Rig("adhesion")
    assert before == MACHINES


# -- the transit machine ---------------------------------------------------------------------------------------
def _transit_cases() -> list[tuple[int, str]]:
    from masonry.fsm.states import TRANSIT_TRANSITIONS

    return [
        (i, src)
        for i, t in enumerate(TRANSIT_TRANSITIONS)
        for src in (t["source"] if isinstance(t["source"], list) else [t["source"]])
    ]


@pytest.mark.parametrize(("index", "source"), _transit_cases())
def test_every_declared_transit_transition(index: int, source: str) -> None:
    from masonry.fsm.states import TRANSIT_TRANSITIONS
    from masonry.fsm.transit import Transit

    t = TRANSIT_TRANSITIONS[index]
    transit = Transit(ignore_invalid_triggers=False)
    transit.machine.set_state(source)
    getattr(transit, t["trigger"])()
    assert transit.state == t["dest"]
    assert transit.active == (t["dest"] != "clear")


def test_transit_triggers_from_a_wrong_phase_are_loud_when_strict() -> None:
    from transitions import MachineError

    from masonry.fsm.transit import Transit

    transit = Transit(ignore_invalid_triggers=False)
    with pytest.raises(MachineError):
        transit.grant()  # nothing was asked for
    transit.begin((1.0, 2.0, 1.2), 2.0, None)
    assert (transit.state, transit.site_m, transit.top_m, transit.layer_m) == (
        "ask",
        (1.0, 2.0, 1.2),
        2.0,
        None,
    )
    with pytest.raises(MachineError):
        transit.arrive()  # not down yet
    transit.drop()
    transit.drop()  # dropping no transit is no trigger at all
    assert transit.state == "clear"


def test_a_uav_machine_in_the_tests_is_strict() -> None:
    from transitions import MachineError

    rig = Rig("brick")
    assert rig.uav.strict_triggers and not rig.uav.machine.ignore_invalid_triggers
    with pytest.raises(MachineError):
        rig.uav.touched()  # idle has no ``touched``


def test_the_diagram_machine_nests_the_transit_states() -> None:
    from masonry.fsm.states import diagram_machine

    for kind in MACHINES:
        states, transitions = diagram_machine(kind)
        assert "transit_ask" in leaf_states(states) and "transit_down" in leaf_states(states)
        assert {
            "trigger": "grant",
            "source": ["transit_ask", "transit_hold"],
            "dest": "transit_down",
        } in transitions
        assert len(transitions) == len(MACHINES[kind][1]) + 5


def test_build_uav_takes_the_clearance_link_explicitly_or_from_the_link() -> None:
    from masonry.fakes import (
        FakeClock,
        FakeFlightController,
        FakeSprayer,
        QueueMissionLink,
        ScriptedClearanceLink,
    )
    from masonry.fsm import UavConfig, build_uav

    clock = FakeClock()
    cfg = UavConfig("glue-1", "adhesion", (0.0, 0.0, 0.0))

    def build(link, **kw):
        return build_uav(
            cfg, fc=FakeFlightController(clock), link=link, clock=clock, sprayer=FakeSprayer(clock), **kw
        )

    airspace = ScriptedClearanceLink([], clock, swaps_batteries=True)
    assert build(airspace).clearance is airspace  # the link implements ClearanceLink too (a mission handler)
    assert build(airspace)._battery_service
    assert build(airspace, clearance=None).clearance is None  # said explicitly: no airspace
    plain = QueueMissionLink([])
    assert build(plain).clearance is None and not build(plain)._battery_service
    assert build(plain, clearance=airspace).clearance is airspace
