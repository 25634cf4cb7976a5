"""The simulated mission's loop: the UAV handlers and mission control at the control period, the world between.

Every control tick (:data:`CONTROL_PERIOD_S`, 0.1 s of simulated time): each live UAV handler reads its messages
and ticks its state machine (a UAV the world failed says nothing more), mission control steps, the observers get
their samples and hooks, then the world advances in steps of ``dt_s``. The loop ends when the UAVs have landed
after the mission's end (or :data:`LANDING_GRACE_S` later), or at ``max_time_s``. After each world step the
mission's envelope watch (:mod:`masonry.mission.envelope`) is shown where the airborne UAVs truly are.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from masonry.mission.control import LANDING_GRACE_S
from masonry.mission.events import SAMPLE_PERIOD_S
from masonry.timing import DEFAULT_TIMING

if TYPE_CHECKING:
    from masonry.mission.simulate import SimulatedMission

#: The state machines' control period (``UavConfig.control_period_s``, from :data:`masonry.timing.DEFAULT_TIMING`):
#: UAV handlers and mission control step at this period, the world at ``dt_s``.
CONTROL_PERIOD_S = DEFAULT_TIMING.control_period_s


def fly(mission: SimulatedMission) -> None:
    """Fly ``mission`` to its end: handlers and mission control at the control period, the world at ``dt_s``."""
    mc, world, clock, handlers, dead = (
        mission.control,
        mission.world,
        mission.clock,
        mission.handlers,
        mission.dead,
    )
    total = sum(1 for t in mission.plan.tasks if not t.done)
    # Handlers and mission control tick at the machines' control rate; the world's physics at dt_s in
    # between. A tick of theirs in between would do nothing the next one does not (the machines act every
    # control_period_s, and an answer to a result is handled at once through ``after_result``).
    dt_s = mission.dt_s
    substeps = max(1, round(CONTROL_PERIOD_S / dt_s)) if dt_s < CONTROL_PERIOD_S else 1
    pre_done = sum(1 for t in mission.plan.tasks if t.done)
    done_seen = len(mc.dispatcher.done) - pre_done
    progress_s = clock.now_s()
    mission_end_s: float | None = None
    next_sample_s = clock.now_s()
    mc.uav_events = False  # the world's samples below tell the sink where each UAV is
    envelope = mission.envelope
    while True:
        now = clock.now_s()
        for name, h in handlers.items():
            if name in dead:
                continue
            if world.uavs[name].failed:
                # a failed UAV (``uav-loss``) says nothing more: mission control must notice the silence
                dead[name] = now
                mission.bus.cut(name)
                continue
            h.step(now)
        mc.step(now)
        if mc.sink is not None and now >= next_sample_s - 1e-9:
            next_sample_s = max(next_sample_s + SAMPLE_PERIOD_S, now)
            live = [(n, u.vehicle) for n, u in world.uavs.items() if n not in dead]
            mc.sample(now, {n: v.position_m for n, v in live}, {n: v.battery_fraction for n, v in live})
        for hook in mission.tick_hooks:
            hook(now)
        if mission.progress is not None:
            n_done = len(mc.dispatcher.done) - pre_done
            if n_done != done_seen or now - progress_s >= 1.0:
                done_seen = n_done
                progress_s = now
                mission.progress(n_done, total, now)
        if mc.ended_at_s is not None:
            if mission_end_s is None:
                mission_end_s = now
            landed = all(h.finished for n, h in handlers.items() if n not in dead)
            if landed or now - mission_end_s > LANDING_GRACE_S:
                break
        if now >= mission.max_time_s:
            break
        for _ in range(substeps):
            world.step(dt_s)
            if envelope is not None:
                envelope.observe(clock.now_s(), world.airborne)  # (armed in the air after the step)
        mission.measured.note_wall()  # (a brick released: the journal file says what the world holds on the wall)
