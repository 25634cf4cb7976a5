"""The brick and adhesion UAV machines as data: nested states and transitions for ``transitions``.

State names carry no underscore: ``transitions`` joins nested names with ``_`` (``pickup_estimate``).
Every leaf state ``s`` has a tick handler ``do_s`` on the model (called once per control tick while the
machine is in ``s``); ``on_enter`` callbacks set up the state's motion target and actuators. Triggers are
fired by the tick handlers; ``abort`` (task failure, battery low) and ``lost`` (flight-controller link lost,
vehicle failure, any hardware error) are the failsafes and can fire from every airborne state.

Brick UAV (paper, Section IV)::

    idle -> takeoff -> pickup {goto, estimate, align, descend, grasp, ascend, verify}
         -> transport -> place {align, descend, release, verify, ascend} -> (pickup | home) -> land -> idle
    (a brick the as-built look saw out of place is lifted and placed again: place_ascend -> reseat {descend,
    grasp, ascend} -> place_align)
    (a task assigned while flying home turns the UAV back: home -> pickup)
    (a task given up with the brick on the magnet puts it back first: -> putback {goto, descend, release,
    ascend} -> home, so that the retry finds it on its pallet)

Adhesion UAV (paper, Section V)::

    idle -> takeoff -> cruise -> hover -> descend -> spray -> close -> ascend -> (cruise | home) -> land -> idle
    (home -> cruise likewise; the task is reported done on entering ascend, and a next segment starting where the
    nozzle is goes ascend -> cruise without climbing: "chaining", docs/state-machines.md)

Failsafes, both machines: ``abort`` -> failsafe -> (home | emergency); ``lost`` -> emergency -> halted
(``landed``, or ``giveup`` when the flight controller stays silent: its own failsafe lands it).
"""

from __future__ import annotations

from typing import Any

State = dict[str, Any]
Transition = dict[str, Any]

#: States every UAV has, around its task-specific ones.
_COMMON_STATES: list[State] = [
    {"name": "idle", "on_enter": "enter_idle"},
    {"name": "takeoff", "on_enter": "enter_takeoff"},
    {"name": "home", "on_enter": "enter_home"},
    {"name": "land", "on_enter": "enter_land"},
    {"name": "failsafe", "on_enter": "enter_failsafe"},
    {"name": "emergency", "on_enter": "enter_emergency"},
    {"name": "halted", "on_enter": "enter_halted"},
]

BRICK_STATES: list[State] = [
    _COMMON_STATES[0],
    _COMMON_STATES[1],
    {
        "name": "pickup",
        "initial": "goto",
        "children": [
            {"name": "goto", "on_enter": "enter_pickup_goto"},
            {"name": "estimate", "on_enter": "enter_pickup_estimate"},
            {"name": "align", "on_enter": "enter_pickup_align"},
            {"name": "descend", "on_enter": "enter_pickup_descend"},
            {"name": "grasp", "on_enter": "enter_pickup_grasp"},
            {"name": "ascend", "on_enter": "enter_pickup_ascend"},
            {"name": "verify", "on_enter": "enter_pickup_verify"},
        ],
    },
    {"name": "transport", "on_enter": "enter_transport"},
    {
        "name": "place",
        "initial": "align",
        "children": [
            {"name": "align", "on_enter": "enter_place_align"},
            {"name": "descend", "on_enter": "enter_place_descend"},
            {"name": "release", "on_enter": "enter_place_release"},
            {"name": "verify", "on_enter": "enter_place_verify"},
            {"name": "ascend", "on_enter": "enter_place_ascend"},
        ],
    },
    {
        # A brick the as-built look saw out of place relative to its neighbours, its glue still open: the UAV comes
        # down onto it, grips it and climbs with it, then places it again (docs/state-machines.md, "Re-seating a
        # brick"; masonry.fsm.reseat)
        "name": "reseat",
        "initial": "descend",
        "children": [
            {"name": "descend", "on_enter": "enter_reseat_descend"},
            {"name": "grasp", "on_enter": "enter_reseat_grasp"},
            {"name": "ascend", "on_enter": "enter_reseat_ascend"},
        ],
    },
    {
        # A task given up while the brick is on the magnet (battery low, a drop-off not reached): the brick goes
        # back where it was picked up, then the UAV flies home (docs/state-machines.md, "Putting a brick back").
        "name": "putback",
        "initial": "goto",
        "children": [
            {"name": "goto", "on_enter": "enter_putback_goto"},
            {"name": "descend", "on_enter": "enter_putback_descend"},
            {"name": "release", "on_enter": "enter_putback_release"},
            {"name": "ascend", "on_enter": "enter_putback_ascend"},
        ],
    },
    *_COMMON_STATES[2:],
]

#: States in which a brick task is under way (``abort`` fires from these).
BRICK_TASK_STATES: list[str] = ["takeoff", "pickup", "transport", "place", "reseat"]
#: States in which the UAV is (or may be) in the air under our control (``lost`` fires from these).
_AIRBORNE_COMMON: list[str] = ["home", "land", "failsafe"]
#: Brick task states in which the brick may be on the magnet (an ``abort`` there puts it back if it is; the
#: magnet may take the brick before the descent ends, as the chaos campaign saw, seed 192).
BRICK_LOADED_STATES: list[str] = [
    "pickup_descend",
    "pickup_grasp",
    "pickup_ascend",
    "pickup_verify",
    "transport",
    "place_align",
    "place_descend",
    "reseat_descend",
    "reseat_grasp",
    "reseat_ascend",
]

BRICK_TRANSITIONS: list[Transition] = [
    {"trigger": "assign", "source": "idle", "dest": "takeoff"},
    {"trigger": "retire", "source": "idle", "dest": "halted"},
    {"trigger": "airborne", "source": "takeoff", "dest": "pickup"},
    {"trigger": "arrived", "source": "pickup_goto", "dest": "pickup_estimate"},
    {"trigger": "widen", "source": "pickup_estimate", "dest": "=", "before": "climb_step"},
    {"trigger": "estimated", "source": "pickup_estimate", "dest": "pickup_align"},
    {"trigger": "aligned", "source": "pickup_align", "dest": "pickup_descend"},
    {"trigger": "touched", "source": "pickup_descend", "dest": "pickup_grasp"},
    {"trigger": "grasped", "source": "pickup_grasp", "dest": "pickup_ascend"},
    {"trigger": "ascended", "source": "pickup_ascend", "dest": "pickup_verify"},
    {"trigger": "attached", "source": "pickup_verify", "dest": "transport"},
    {"trigger": "missed", "source": "pickup_verify", "dest": "pickup_estimate"},
    {"trigger": "arrived", "source": "transport", "dest": "place"},
    {"trigger": "aligned", "source": "place_align", "dest": "place_descend"},
    {"trigger": "reached", "source": "place_descend", "dest": "place_release"},
    {"trigger": "timeout", "source": "place_descend", "dest": "place_align"},
    {"trigger": "released", "source": "place_release", "dest": "place_verify"},
    {"trigger": "deposited", "source": "place_verify", "dest": "place_ascend"},
    {"trigger": "stuck", "source": "place_verify", "dest": "place_release"},
    {"trigger": "reseat", "source": "place_ascend", "dest": "reseat"},
    {"trigger": "touched", "source": "reseat_descend", "dest": "reseat_grasp"},
    {"trigger": "grasped", "source": "reseat_grasp", "dest": "reseat_ascend"},
    {"trigger": "attached", "source": "reseat_ascend", "dest": "place_align"},
    {"trigger": "missed", "source": "reseat_ascend", "dest": "place_ascend"},
    {"trigger": "finish", "source": "place_ascend", "dest": "pickup", "conditions": "has_next_task"},
    {"trigger": "finish", "source": "place_ascend", "dest": "home"},
    {"trigger": "assign", "source": "home", "dest": "pickup"},
    {"trigger": "arrived", "source": "home", "dest": "land"},
    {"trigger": "landed", "source": "land", "dest": "halted", "conditions": "must_halt"},
    {"trigger": "landed", "source": "land", "dest": "idle"},
    # before the general abort: transitions tries these first (a leaf's, then its parent's)
    {
        "trigger": "abort",
        "source": BRICK_LOADED_STATES,
        "dest": "putback",
        "conditions": "may_put_back",
        "before": "defer_failure",
    },
    {"trigger": "abort", "source": BRICK_TASK_STATES, "dest": "failsafe", "before": "fail_task"},
    {"trigger": "recover", "source": "failsafe", "dest": "home"},
    {"trigger": "arrived", "source": "putback_goto", "dest": "putback_descend"},
    {"trigger": "reached", "source": "putback_descend", "dest": "putback_release"},
    {"trigger": "released", "source": "putback_release", "dest": "putback_ascend"},
    {"trigger": "finish", "source": "putback_ascend", "dest": "home", "before": "fail_task"},
    {"trigger": "stow", "source": "putback", "dest": "home", "before": "keep_brick"},
    {
        "trigger": "lost",
        "source": [*BRICK_TASK_STATES, "putback", *_AIRBORNE_COMMON],
        "dest": "emergency",
        "before": "fail_task",
    },
    {"trigger": "landed", "source": "emergency", "dest": "halted"},
    {"trigger": "giveup", "source": "emergency", "dest": "halted"},
]

ADHESION_STATES: list[State] = [
    _COMMON_STATES[0],
    _COMMON_STATES[1],
    {"name": "cruise", "on_enter": "enter_cruise"},
    {"name": "hover", "on_enter": "enter_hover"},
    {"name": "descend", "on_enter": "enter_descend"},
    {"name": "spray", "on_enter": "enter_spray"},
    {"name": "close", "on_enter": "enter_close"},
    {"name": "ascend", "on_enter": "enter_ascend"},
    *_COMMON_STATES[2:],
]

ADHESION_TASK_STATES: list[str] = ["takeoff", "cruise", "hover", "descend", "spray", "close", "ascend"]

ADHESION_TRANSITIONS: list[Transition] = [
    {"trigger": "assign", "source": "idle", "dest": "takeoff"},
    {"trigger": "retire", "source": "idle", "dest": "halted"},
    {"trigger": "airborne", "source": "takeoff", "dest": "cruise"},
    {"trigger": "arrived", "source": "cruise", "dest": "hover"},
    {"trigger": "stable", "source": "hover", "dest": "descend"},
    {"trigger": "reached", "source": "descend", "dest": "spray"},
    {"trigger": "sprayed", "source": "spray", "dest": "close"},
    {"trigger": "closed", "source": "close", "dest": "ascend"},
    {"trigger": "finish", "source": "ascend", "dest": "cruise", "conditions": "has_next_task"},
    {"trigger": "finish", "source": "ascend", "dest": "home"},
    {"trigger": "assign", "source": "home", "dest": "cruise"},
    {"trigger": "arrived", "source": "home", "dest": "land"},
    {"trigger": "landed", "source": "land", "dest": "halted", "conditions": "must_halt"},
    {"trigger": "landed", "source": "land", "dest": "idle"},
    {"trigger": "abort", "source": ADHESION_TASK_STATES, "dest": "failsafe", "before": "fail_task"},
    {"trigger": "recover", "source": "failsafe", "dest": "home"},
    {
        "trigger": "lost",
        "source": [*ADHESION_TASK_STATES, *_AIRBORNE_COMMON],
        "dest": "emergency",
        "before": "fail_task",
    },
    {"trigger": "landed", "source": "emergency", "dest": "halted"},
    {"trigger": "giveup", "source": "emergency", "dest": "halted"},
]

#: The airspace transit protocol (docs/safety.md), a machine of its own beside the task machine: a lateral move
#: with a clearance link asks for the column over its site (``ask``, hovering where it stopped), may be sent to
#: wait at a hold point on its layer (``hold``), and once granted flies its layer route and comes down there
#: (``down``), then ends the transit (``arrive``, freeing its layer). Every move (``cancel``) drops it.
TRANSIT_STATES: list[State] = [
    {"name": "clear"},
    {"name": "ask"},
    {"name": "hold"},
    {"name": "down"},
]

TRANSIT_TRANSITIONS: list[Transition] = [
    {"trigger": "request", "source": ["clear", "ask", "hold", "down"], "dest": "ask"},
    {"trigger": "wait", "source": ["ask", "hold"], "dest": "hold"},
    {"trigger": "grant", "source": ["ask", "hold"], "dest": "down"},
    {"trigger": "arrive", "source": "down", "dest": "clear"},
    {"trigger": "cancel", "source": ["ask", "hold", "down"], "dest": "clear"},
]

#: The transit machine as one nested state, for the diagrams (``masonry fsm diagram``).
TRANSIT: State = {"name": "transit", "initial": "clear", "children": TRANSIT_STATES}

MACHINES: dict[str, tuple[list[State], list[Transition]]] = {
    "brick": (BRICK_STATES, BRICK_TRANSITIONS),
    "adhesion": (ADHESION_STATES, ADHESION_TRANSITIONS),
}


def diagram_machine(kind: str) -> tuple[list[State], list[Transition]]:
    """The states and transitions drawn for machine ``kind``: its own, and the transit machine nested beside them
    (a brick or adhesion UAV runs both)."""
    states, transitions = MACHINES[kind]
    transit = [
        {
            **t,
            "source": [
                f"transit_{s}" for s in (t["source"] if isinstance(t["source"], list) else [t["source"]])
            ],
            "dest": f"transit_{t['dest']}",
        }
        for t in TRANSIT_TRANSITIONS
    ]
    return [*states, TRANSIT], [*transitions, *transit]


def leaf_states(states: list[State], prefix: str = "") -> list[str]:
    """Full names (``parent_child``) of the leaf states of a nested state list, in declaration order."""
    names: list[str] = []
    for state in states:
        name = prefix + state["name"]
        children = state.get("children")
        if children:
            names.extend(leaf_states(children, name + "_"))
        else:
            names.append(name)
    return names


def triggers(transitions: list[Transition]) -> list[str]:
    """The distinct trigger names of a transition list, in declaration order."""
    return list(dict.fromkeys(t["trigger"] for t in transitions))
