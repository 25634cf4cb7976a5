"""The site's geofence on the UAV: setpoints clamped inside it, and a UAV blown out of it stopped (pure).

The navigator keeps every target and reference position ``SETPOINT_MARGIN_M`` inside the fence
(:func:`clamp_reference`); the model watches the telemetry (:class:`FenceWatch`): a UAV seen more than
``BREACH_MARGIN_M`` outside gives its task up with the reason (the attempt counts), hovers where the clamped
setpoint holds it (inside) and flies home from there; one still outside ``UavConfig.fence_return_s`` later lands
where it is (docs/state-machines.md, "The site's fence").
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from masonry.geofence import BREACH_MARGIN_M, SETPOINT_MARGIN_M, Site


def clamp_reference(site: Site | None, p_m: Any) -> tuple[Any, bool]:
    """``p_m`` moved ``SETPOINT_MARGIN_M`` inside the fence (a float tuple), and whether it had to be."""
    if site is None:
        return p_m, False
    x, y, z = float(p_m[0]), float(p_m[1]), float(p_m[2])
    c = site.clamp_m((x, y, z), SETPOINT_MARGIN_M)
    if c == (x, y, z):
        return p_m, False
    return c, True


class FenceWatch:
    """Whether, and since when, a UAV is outside its fence by more than ``breach_margin_m``.

    Attributes:
        outside_m: how far outside it was at the last look (0 or less: inside).
        since_s: since when it has been outside beyond the margin (None: it is not).
    """

    def __init__(self, site: Site, breach_margin_m: float = BREACH_MARGIN_M) -> None:
        self.site = site
        self.breach_margin_m = float(breach_margin_m)
        self.outside_m = 0.0
        self.since_s: float | None = None

    def observe(self, now_s: float, position_m: Sequence[float]) -> bool:
        """Look at the UAV at ``position_m``: True while it is outside beyond the margin."""
        self.outside_m = self.site.outside_by_m(position_m)
        if self.outside_m <= self.breach_margin_m:
            self.since_s = None
            return False
        if self.since_s is None:
            self.since_s = float(now_s)
        return True

    def out_for_s(self, now_s: float) -> float:
        """How long it has been outside beyond the margin (0: it is not)."""
        return 0.0 if self.since_s is None else float(now_s) - self.since_s


__all__ = ["FenceWatch", "clamp_reference"]


#: States in which a UAV outside its fence is neither given up on nor landed: on the ground, landing, or already
#: out of the machine's hands.
_LEFT_ALONE = frozenset({"idle", "land", "emergency", "halted"})


def watch_fence(model: Any, watch: FenceWatch, now_s: float, position_m: Sequence[float]) -> None:
    """The model's look at its fence each tick (``masonry.fsm.model.UavModel.step``).

    Outside beyond the margin during a task: the task is given up with the reason (``abort``: it hovers, inside
    its clamped setpoint, then flies home). Still outside ``fence_return_s`` later, in any airborne state:
    ``lost`` (it lands where it is).
    """
    if not watch.observe(now_s, position_m):
        return
    state = model.state
    x, y, z = (float(v) for v in position_m)
    if model.task is not None and state in model._TASK_STATES_SET:
        model.abort(
            reason=f"outside the site fence by {watch.outside_m:.2f} m at ({x:.2f}, {y:.2f}, {z:.2f})"
        )
    elif state not in _LEFT_ALONE and watch.out_for_s(now_s) > model.config.fence_return_s:
        model.lost(
            reason=f"could not get back inside the site fence within {model.config.fence_return_s:.0f} s "
            f"(outside by {watch.outside_m:.2f} m at ({x:.2f}, {y:.2f}, {z:.2f})): landing where it is"
        )
