"""The site columns a UAV asks mission control for: the handler's :class:`~masonry.ports.ClearanceLink`.

Airspace (docs/safety.md): ``request_clearance(site_m)`` is how the state machine asks for the column over a
site before leaving its transit layer; the handler sends a ``ClearanceRequest`` (again every heartbeat period
while unanswered), answers True once mission control's ``Clearance`` has come, and frees the column by itself
once the UAV is ``radius_m`` away from it horizontally or has landed. The answer also gives the altitude of the
lateral leg (a transit layer) and, while the column is taken, a hold point where the machine waits at that
layer; ``end_transit`` tells mission control the flight is down (its layer is free).

:class:`ColumnRequests` is a base class of :class:`~masonry.mission.handler.UavHandler`: it asks, hears the
answers (``_on_clearance``) and frees what the UAV has left (``_check_columns``, each step).
"""

from __future__ import annotations

from masonry.mission.handler_base import HandlerBase, Vec3
from masonry.mission.messages import MISSION_CONTROL, Clearance, ClearanceRequest
from masonry.ports import LAST_RESORT_S


class ColumnRequests(HandlerBase):
    """The columns this UAV asked for, holds and frees (see the module)."""

    def _init_columns(self) -> None:
        self._column: Vec3 | None = None  # site of the column last asked for (granted or not)
        self._column_granted = False
        # a new attempt asks again even for the column it was granted last (issue 19): it may have flown off
        self._column_stale = False
        self._column_answer: Clearance | None = None
        self._columns_left: list[Vec3] = []  # granted earlier, freed once the UAV is out of them
        self._column_radius_m = 0.0
        self._column_sent_s = -1e18
        self._column_top_m: float | None = None
        self._column_to_m: Vec3 | None = None
        self._column_checked_s = -1e18
        self.clearance_requests = 0

    def _ask_afresh(self) -> None:
        """A new attempt: the column granted for the last one is asked for again (issue 19)."""
        self._column_stale = self._column is not None and self._column_granted

    def request_clearance(
        self, site_m: Vec3, top_m: float | None = None, to_m: Vec3 | None = None
    ) -> Clearance | None:
        """The UAV sets off for ``site_m``: mission control's answer (layer, column granted or hold point), or None.

        The first call for a site sends the request (again every heartbeat period while unanswered); the answer
        is None until mission control's has come, then the latest one (``granted`` turns true when the column
        is given). Mission control silent (a link down) is asked again every heartbeat period: the UAV hovers
        where it stopped, its task abandoned, until mission control answers. Without mission control (never
        heard, or silent for ``LAST_RESORT_S``) there is nobody to ask: granted, no layer, so the UAV can land.
        """
        site = (float(site_m[0]), float(site_m[1]), float(site_m[2]))
        col = self._column
        same = col is not None and abs(col[0] - site[0]) < 1e-3 and abs(col[1] - site[1]) < 1e-3
        if same and self._column_granted and not self._column_stale:
            return self._column_answer
        if self._last_mc_s is None or self.now_s - self._last_mc_s > LAST_RESORT_S:
            # nobody to ask: never heard (no mission), or silent so long it is not coming back
            return Clearance(MISSION_CONTROL, self.name, site, 0.0, self.now_s, True, None, None)
        if not same:
            if col is not None and self._column_granted:
                self._columns_left.append(col)  # freed once the UAV is out of it
            elif col is not None:
                self._send(ClearanceRequest(self.name, col, self.now_s, release=True))  # no longer wanted
            self._column = site
            self._column_granted = False
            self._column_answer = None
            self._column_sent_s = self.now_s
            self.clearance_requests += 1
            self._column_top_m = top_m
            self._column_to_m = None if to_m is None else (float(to_m[0]), float(to_m[1]), float(to_m[2]))
            self._send(
                ClearanceRequest(
                    self.name, site, self.now_s, self._where(), top_m=top_m, to_m=self._column_to_m
                )
            )
        elif self._column_stale or self.now_s - self._column_sent_s >= (
            0.25
            if self._column_answer is not None and self._column_answer.hold_m is None
            else self.heartbeat_period_s
        ):  # refused for now (another flight in the way): ask again soon
            if self._column_stale:  # a new attempt: a fresh request from where it is now, not the old grant
                self._column_stale = False
                self._column_granted = False
                self._column_answer = None
                self.clearance_requests += 1
                self._column_top_m = top_m
                self._column_to_m = None if to_m is None else (float(to_m[0]), float(to_m[1]), float(to_m[2]))
            self._column_sent_s = self.now_s  # lost on the way? ask again (mission control keeps its place)
            self._send(
                ClearanceRequest(
                    self.name,
                    site,
                    self.now_s,
                    self._where(),
                    top_m=self._column_top_m,
                    to_m=self._column_to_m,
                )
            )
        self.pump()  # in-process, the answer may already be here
        return self._column_answer

    def end_transit(self, site_m: Vec3) -> None:
        """The flight to ``site_m`` has come down there: its layer is free."""
        self._send(
            ClearanceRequest(
                self.name, (float(site_m[0]), float(site_m[1]), float(site_m[2])), self.now_s, arrived=True
            )
        )

    @property
    def columns(self) -> tuple[Vec3, ...]:
        """Sites of the columns this UAV holds."""
        cur = (self._column,) if self._column is not None and self._column_granted else ()
        return tuple(self._columns_left) + cur

    def _check_columns(self, now_s: float) -> None:
        """Free columns the UAV has left (``radius_m`` away horizontally); all of them once it has landed."""
        if now_s - self._column_checked_s < 0.2:
            return
        self._column_checked_s = now_s
        model = self.model
        if model is not None and bool(model.finished):
            for col in [*self._columns_left, *([self._column] if self._column is not None else [])]:
                self._send(ClearanceRequest(self.name, col, now_s, release=True))
            self._columns_left = []
            self._column = None
            self._column_granted = False
            return
        if not self._columns_left or self._position is None:
            return
        p = self._position()
        r2 = self._column_radius_m**2
        keep = []
        for col in self._columns_left:
            if (p[0] - col[0]) ** 2 + (p[1] - col[1]) ** 2 >= r2:
                self._send(ClearanceRequest(self.name, col, now_s, release=True))
            else:
                keep.append(col)
        self._columns_left = keep

    def _on_clearance(self, msg: Clearance) -> None:
        """Mission control's answer about a column: kept if it is about the column asked for last."""
        col = self._column
        if (
            msg.uav == self.name
            and col is not None
            and abs(col[0] - msg.site_m[0]) < 1e-3
            and abs(col[1] - msg.site_m[1]) < 1e-3
        ):
            self._column_radius_m = msg.radius_m
            if msg.granted or not self._column_granted:
                self._column_answer = msg
                self._column_granted = msg.granted


__all__ = ["ColumnRequests"]
