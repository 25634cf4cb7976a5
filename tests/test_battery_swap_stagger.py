"""Battery swaps one after another (masonry.mission.swap_stagger) and the swap of a UAV idle on its pad
(``UavHandler.top_up_fraction``), under the defaults."""

from __future__ import annotations

from pathlib import Path

from masonry.battery_drain import DrainMeter
from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.control import MissionControl
from masonry.mission.handler import TOP_UP_FRACTION
from masonry.mission.simulate import SimulatedMission
from masonry.mission.swap_stagger import RESERVE, SWAP_EARLY, core_of, swap_due
from masonry.mission.uav_facts import UavFacts


def test_one_uav_per_four_of_a_role_is_sent_for_an_early_swap_and_stays_sent_until_its_fresh_pack() -> None:
    """Under ``SWAP_EARLY`` with no task and a ground crew, a UAV is given none (it flies home for a fresh pack)
    while fewer than one in four of its role are sent and another is there to work; once sent it stays sent until a
    fresh pack is heard, whoever else comes and goes between tasks; in a role of fewer than four, never."""
    mission = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=4, adhesion_uavs=2), seed=0)
    mc = mission.control
    for link in mc.uavs.values():
        link.swaps_batteries = True  # as its heartbeats say (simulated: a ground crew)
    assert not mc.dispatcher.task_of("brick-1")  # nothing dispatched yet
    low = SWAP_EARLY - 0.05
    assert not swap_due(mc, "brick-1")  # no battery heard yet
    mc.uavs["brick-1"].battery = SWAP_EARLY
    assert not swap_due(mc, "brick-1")  # at the line: it works on
    mc.uavs["brick-1"].battery = low
    assert swap_due(mc, "brick-1")
    mc.uavs["brick-2"].battery = low
    assert not swap_due(mc, "brick-2")  # brick-1 is sent for its swap: one of four at a time
    assert swap_due(mc, "brick-1")  # and stays sent while brick-2, low too, is between tasks
    mc.uavs["brick-1"].battery = 1.0  # brick-1's fresh pack
    assert not swap_due(mc, "brick-1")
    assert swap_due(mc, "brick-2")
    mc.uavs["glue-2"].battery = 0.9
    mc.uavs["glue-1"].battery = low
    assert not swap_due(mc, "glue-1")  # two of a role (fewer than four): never sent early
    assert TOP_UP_FRACTION == SWAP_EARLY  # given nothing, a UAV sent home early is swapped on its pad

    alone = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=1, adhesion_uavs=1), seed=0).control
    alone.uavs["brick-1"].battery = alone.uavs["glue-1"].battery = RESERVE + 0.05
    alone.uavs["brick-1"].swaps_batteries = alone.uavs["glue-1"].swaps_batteries = True
    assert not swap_due(alone, "brick-1") and not swap_due(alone, "glue-1")


def test_a_uav_under_the_handlers_reserve_is_given_no_task_whatever_its_role_does() -> None:
    """Under ``RESERVE`` its handler would hold any task for the swap (the flight home, the crew's minute, the
    take-off) with the task in progress for mission control: a UAV with a ground crew is given none instead, in a
    role of any size and beside a UAV already sent; it stays sent until its fresh pack is heard. Without a ground
    crew, never (its handler retires it); nor while a UAV of its role waits on its pad with a good pack (a spare
    would take the task and lay the rest from its pad)."""
    alone = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=1, adhesion_uavs=1), seed=0).control
    alone.uavs["brick-1"].battery = RESERVE - 0.01
    assert not swap_due(alone, "brick-1")  # no ground crew heard of
    alone.uavs["brick-1"].swaps_batteries = True
    assert swap_due(alone, "brick-1")  # one of a role
    alone.uavs["brick-1"].battery = RESERVE + 0.01  # a heartbeat a little higher (a sag over): still sent
    assert swap_due(alone, "brick-1")
    alone.uavs["brick-1"].battery = 1.0
    assert not swap_due(alone, "brick-1")

    mc = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=4, adhesion_uavs=2), seed=0).control
    for link in mc.uavs.values():
        link.swaps_batteries = True
    mc.uavs["brick-1"].battery = SWAP_EARLY - 0.05
    assert swap_due(mc, "brick-1")  # sent early: the one of four
    mc.uavs["brick-4"].battery = 0.9
    mc.uavs["brick-4"].facts = UavFacts(on_pad=True)  # a spare on its pad
    mc.uavs["brick-2"].battery = RESERVE - 0.01
    assert not swap_due(mc, "brick-2")
    mc.uavs["brick-4"].facts = UavFacts()  # it flies
    assert swap_due(mc, "brick-2")  # under the reserve: beside brick-1, already sent
    assert set(mc.swaps.sent_s) == {"brick-1", "brick-2"}


def test_no_uav_is_sent_without_a_ground_crew_with_a_spare_on_its_pad_or_with_a_pack_that_covers_its_share() -> (
    None
):
    """A UAV whose heartbeats do not say a ground crew swaps its pack would sit on its pad unswapped: never sent.
    Nor while a UAV of its role waits on its pad with a good pack and no task (the fleet has more of the role
    than the wall uses), nor when its pack above the reserve covers its share of the work of its role left."""
    mission = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=4, adhesion_uavs=2), seed=0)
    mc = mission.control
    low = SWAP_EARLY - 0.05
    for name in ("brick-1", "brick-2", "brick-3", "brick-4"):
        mc.uavs[name].battery = low
    assert not swap_due(mc, "brick-1")  # no ground crew heard of
    for link in mc.uavs.values():
        link.swaps_batteries = True
    mc.uavs["brick-4"].battery = 0.9
    mc.uavs["brick-4"].facts = UavFacts(on_pad=True)
    assert not swap_due(mc, "brick-1")  # brick-4 waits on its pad with a good pack
    mc.uavs["brick-4"].facts = UavFacts()  # it flies
    meter = DrainMeter()
    meter.update(0.0, 1.0, airborne=True)
    meter.update(100.0, 0.99, airborne=True)  # 1e-4 per airborne second: 1,000 s of flight to the reserve
    mc.lingers.drains["brick-1"] = meter
    share_s = mc.swaps.share_left_s(mc, "brick")
    assert 0.0 < share_s < 0.1 / 1e-4  # 16 bricks over four UAVs
    assert mc.swaps.covers(mc, "brick-1")
    assert not swap_due(mc, "brick-1")
    assert swap_due(mc, "brick-2")  # no drain measured: it does not count on its pack
    assert mc.swaps.sent_s == {"brick-2": mc.now_s}


def test_the_ground_crew_swaps_an_idle_uav_on_its_pad_and_a_task_handed_over_meanwhile_starts_at_once() -> (
    None
):
    """Landed with nothing to do under ``TOP_UP_FRACTION``, a UAV's pack is swapped after the crew's time; a task
    handed over before that, which the battery covers, starts at once (the swap is left off: the next one starts
    afresh)."""
    mission = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=1, adhesion_uavs=1), seed=0)
    handler = mission.handlers["glue-1"]
    vehicle = mission.world.uavs["glue-1"].vehicle
    crew = handler._swap_battery
    vehicle.battery_fraction = TOP_UP_FRACTION - 0.1
    clock = mission.clock
    start_s = clock.now_s()
    while clock.now_s() - start_s < 30.0:  # half a swap, the UAV idle on its pad
        handler.step(clock.now_s())
        mission.world.step(0.1)
    assert handler.top_ups == 0 and vehicle.battery_fraction < TOP_UP_FRACTION
    for _ in range(30):  # ticks away from the crew (a flight): the swap left off starts afresh
        mission.world.step(0.1)
    handler.step(clock.now_s())
    assert crew._since_s == clock.now_s()
    while handler.top_ups == 0 and clock.now_s() - start_s < 200.0:
        handler.step(clock.now_s())
        mission.world.step(0.1)
    assert handler.top_ups == handler.battery_swaps == 1
    assert vehicle.battery_fraction == 1.0


def test_a_simulated_uavs_heartbeat_says_its_ground_crew_swaps_its_pack() -> None:
    """The simulator's UAVs have a ground crew (``UavHandler.swaps_batteries``); their heartbeats say so, and
    mission control, which cannot see the crew, reads it there."""
    mission = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=1, adhesion_uavs=1), seed=0)
    handler = mission.handlers["glue-1"]
    assert handler.swaps_batteries
    assert not mission.control.uavs["glue-1"].swaps_batteries  # nothing heard yet
    handler.step(mission.clock.now_s())  # its first heartbeat
    mission._step_control()
    assert mission.control.uavs["glue-1"].swaps_batteries


def test_a_roles_one_busy_uav_under_the_reserve_is_sent_beside_a_spare() -> None:
    """On a wall the admission rule keeps to one busy UAV of a role (the bundled pyramid's sprayers at 4 + 2),
    that UAV under ``RESERVE`` is sent home even with a spare on its pad: held by its handler, its task would
    stop the role's work for the whole swap; the spare takes it. A role capped higher keeps the spare rule."""
    pyramid = Path(__file__).resolve().parent.parent / "blueprints" / "pyramid.yaml"
    mc = SimulatedMission.from_blueprint(
        load_blueprint(pyramid), brick_uavs=4, adhesion_uavs=2, seed=0
    ).control
    assert mc.dispatcher.capped_alone("adhesion") and not mc.dispatcher.capped_alone("brick")
    for link in mc.uavs.values():
        link.swaps_batteries = True
        link.battery = 0.9
    for spare in ("glue-2", "brick-4"):
        mc.uavs[spare].facts = UavFacts(on_pad=True)  # spares on their pads, no task
    mc.uavs["glue-1"].battery = mc.uavs["brick-1"].battery = RESERVE - 0.01
    assert swap_due(mc, "glue-1")
    assert not swap_due(mc, "brick-1")  # three brick UAVs may be busy: the spare rule holds


def test_while_a_roles_spares_rest_its_core_swaps_as_the_core_alone_would() -> None:
    """4 + 4 (core 4 + 2): while the sprayers are not the wall's pace their spares rest on their pads, and a core
    sprayer under ``SWAP_EARLY`` is not sent early (a core of two never is, as at 4 + 2); under ``RESERVE`` it is.
    With the sprayers the pace, the role of four sends one early and a spare takes its place."""

    def control(done_kind: str) -> MissionControl:
        mission = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=4, adhesion_uavs=4), seed=0)
        mc = mission.control
        done = [t.id for t in mc.plan.tasks if t.kind == done_kind and not t.done][2:]
        mc.dispatcher.restore(done, {})  # all of one role's tasks done but two
        for link in mc.uavs.values():
            link.swaps_batteries = True
            link.battery = 0.9
        for spare in ("glue-3", "glue-4"):
            mc.uavs[spare].facts = UavFacts(on_pad=True)
        return mc

    mc = control("adhesion")  # two segments left, the bricks the pace
    assert mc.swaps.resting(mc, "adhesion") and not mc.swaps.resting(mc, "brick")
    assert core_of(mc, "adhesion") == ["glue-1", "glue-2"]
    mc.uavs["glue-1"].battery = SWAP_EARLY - 0.05
    assert not swap_due(mc, "glue-1")
    mc.uavs["glue-1"].battery = RESERVE - 0.01
    assert swap_due(mc, "glue-1")

    mc = control("brick")  # two bricks left, the sprayers the pace
    assert not mc.swaps.resting(mc, "adhesion")
    mc.uavs["glue-1"].battery = SWAP_EARLY - 0.05
    assert swap_due(mc, "glue-1")
