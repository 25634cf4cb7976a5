"""A retry asks for a fresh grant (issue 19): neither the handler nor the airspace hands out the last one again.

On ArduCopter SITL an adhesion UAV failed safe over A0, flew home outside the protocol and tried again: its
handler answered the retry's request with the grant cached from the first attempt, and mission control's
airspace would have too (same site), so the UAV flew a route whose climb was reserved where it had been, not
where it was.
"""

from __future__ import annotations

from masonry.blueprint_gen import running_bond
from masonry.mission.airspace import ColumnClearance
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL
from masonry.mission.volumes import contains
from masonry.planner import plan

R, BASE, S = 1.5, 1.35, 1.1


def test_a_repeated_request_from_inside_the_flight_keeps_it_and_one_from_elsewhere_is_evaluated_afresh():
    c = ColumnClearance(R, BASE, S)
    site = (0.0, 0.0, 1.2)
    first = c.request("a", site, 0.0, (0.0, -4.0, 1.2))
    assert first.granted
    climb = c.volumes("a")[0]
    assert climb.kind == "climb" and climb.a == (0.0, -4.0)
    # asked again from where it set off (a message repeated): the same flight, nothing re-reserved
    assert c.request("a", site, 1.0, (0.0, -4.0, 1.2)) == first
    assert c.volumes("a")[0] == climb
    # b works 4 m to the side: a's retry from next to b (it was flown off its route) is not granted blindly
    c.request("b", (4.5, -4.0, 1.2), 1.0, (4.5, -4.0, 1.2))
    c.end_transit("b")
    retry = c.request("a", site, 2.0, (4.0, -3.5, 1.2))
    assert not retry.granted, "a climb within the separation of b's zone was granted from the old flight"
    # from a clear place the fresh flight climbs where the UAV is now
    again = c.request("a", site, 3.0, (-4.0, -4.0, 1.2))
    assert again.granted
    assert c.volumes("a")[0].a == (-4.0, -4.0)
    assert contains(c.volumes("a"), -4.0, -4.0, 1.2)
    assert not contains(c.volumes("a"), 0.0, -4.0, 1.2, margin_m=0.0)


def _mission():
    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=1)
    bus = InprocBus()
    mc = MissionControl(
        plan(bp),
        bp.fleet,
        bus.endpoint(MISSION_CONTROL),
        column_radius_m=R,
        layer_base_m=BASE,
        startup_timeout_s=100.0,
    )
    where = {u.name: (u.home_m[0], u.home_m[1], 1.2) for u in bp.fleet}
    handlers = {
        u.name: UavHandler(u.name, bus.endpoint(u.name), position=lambda n=u.name: where[n]) for u in bp.fleet
    }
    return bp, mc, handlers, where, bus


def test_a_new_attempt_sends_a_fresh_request_for_the_column_it_was_granted_before():
    bp, mc, handlers, where, _bus = _mission()
    name = next(u.name for u in bp.fleet if u.role == "brick")
    h = handlers[name]
    t = 0.0
    for h_ in handlers.values():
        h_.step(t)
    mc.step(t)
    for step in range(1, 6):
        t = 0.1 * step
        for h_ in handlers.values():
            h_.step(t)
        mc.step(t)
    task = h.poll_task()
    assert task is not None
    site = (1.0, 1.0, 1.2)
    assert h.request_clearance(site) is None
    mc.step(t + 0.1)
    assert h.request_clearance(site).granted
    asked = h.clearance_requests
    # the attempt fails (its result reported), the same UAV gets the task again after a failsafe flew it home
    from masonry.ports import TaskResult

    h.report_result(TaskResult(task.id, "failed", 0.3, reason="could not hover still"))
    t += 0.2
    mc.step(t)
    h.step(t + 0.05)
    again = h.poll_task()
    assert again is not None and again.id == task.id
    where[name] = (bp.fleet[0].home_m[0], bp.fleet[0].home_m[1], 1.2)
    assert h.request_clearance(site) is None, "the retry was answered with the first attempt's grant"
    assert h.clearance_requests == asked + 1
    mc.step(t + 0.2)
    answer = h.request_clearance(site)
    assert answer is not None and answer.granted
