"""Battery swaps one after another (masonry.mission.swap_stagger) and the swap of a UAV idle on its pad
(``UavHandler.top_up_fraction``), under the defaults."""

from __future__ import annotations

from masonry.blueprint_gen import running_bond
from masonry.mission.handler import TOP_UP_FRACTION
from masonry.mission.simulate import SimulatedMission
from masonry.mission.swap_stagger import SWAP_EARLY, swap_due


def test_one_uav_per_four_of_a_role_is_sent_for_an_early_swap_at_a_time() -> None:
    """Under ``SWAP_EARLY`` with no task, a UAV is given none (it flies home for a fresh pack) while fewer than one
    in four of its role (at least one) are away for theirs and another is there to work; a lone UAV never."""
    mission = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=4, adhesion_uavs=2), seed=0)
    mc = mission.control
    assert not mc.dispatcher.task_of("brick-1")  # nothing dispatched yet
    low = SWAP_EARLY - 0.05
    assert not swap_due(mc, "brick-1")  # no battery heard yet
    mc.uavs["brick-1"].battery = SWAP_EARLY
    assert not swap_due(mc, "brick-1")  # at the line: it works on
    mc.uavs["brick-1"].battery = low
    assert swap_due(mc, "brick-1")
    mc.uavs["brick-2"].battery = low
    assert not swap_due(mc, "brick-2")  # brick-1 is away for its swap: one of four at a time
    mc.uavs["brick-1"].battery = 1.0  # brick-1's fresh pack
    assert swap_due(mc, "brick-2")
    mc.uavs["glue-2"].battery = 0.9
    mc.uavs["glue-1"].battery = low
    assert swap_due(mc, "glue-1")
    mc.uavs["glue-2"].battery = low
    assert not swap_due(mc, "glue-2")  # two of a role: one at a time
    assert TOP_UP_FRACTION == SWAP_EARLY  # given nothing, a UAV sent home early is swapped on its pad

    alone = SimulatedMission.from_blueprint(running_bond(2, 8, brick_uavs=1, adhesion_uavs=1), seed=0).control
    alone.uavs["brick-1"].battery = alone.uavs["glue-1"].battery = 0.2
    assert not swap_due(alone, "brick-1") and not swap_due(alone, "glue-1")


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
