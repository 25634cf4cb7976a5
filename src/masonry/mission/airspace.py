"""Airspace separation between UAVs: reserved volumes, handed out by mission control at run time.

The paper's conflict graph G^c keeps the task *locations* r_c apart; it says nothing about the flights between
them, the shared pallet or the pads. :class:`ColumnClearance` closes that gap (docs/safety.md). The state
machines fly exactly its shapes: climb (or descend) vertically where they are, fly straight at the layer, come
down vertically over the site (``masonry.fsm``). Mission control runs the rules, so they work the same in-process
and across Zenoh (messages ``clearance-request`` / ``clearance``). Everything here is pure (no I/O, no clock).

ColumnClearance is the protocol; its records, the layers and the volumes' shapes are its base,
:class:`~masonry.mission.airspace_records.AirspaceRecords`; how a granted flight shrinks as it is flown is
:mod:`~masonry.mission.airspace_progress`.
"""

from __future__ import annotations

from collections.abc import Sequence

from masonry.mission import airspace_ground, airspace_progress, airspace_queries, airspace_requests
from masonry.mission.airspace_ground import ON_PAD_XY_M, ON_PAD_Z_M
from masonry.mission.airspace_progress import AT_HOLD_M
from masonry.mission.airspace_records import SNAP_M, AirspaceRecords
from masonry.mission.airspace_state import Grant, Phase
from masonry.mission.altitudes import (
    DEFAULT_LAYER_SPACING_M,
    layer_base_m,
    task_work_altitude_m,
    transit_layers_m,
    work_altitude_m,
)
from masonry.mission.sites import SiteGate
from masonry.mission.volumes import HOVER_SLACK_M, STOP_M, TRACK_M, Vec3, Volume, volumes_conflict
from masonry.mission.volumes import point_segment_m as _point_segment_m  # noqa: F401 - the tests' name


class ColumnClearance(AirspaceRecords):
    """The airspace at run time: every UAV's reserved volumes, never within the separation of another's.

    Each UAV holds a set of :class:`Volume`: where it is working (a *zone*: the column over its site, from the
    ground to the highest altitude it reaches there, with the work's horizontal slack), or the whole of a flight
    it was granted: the climb where it set off, the lateral leg at its layer, the column over its site. A flight
    is granted only if all of it keeps the separation from every volume of every other UAV, so two UAVs that
    stay in their volumes never come closer than min(``sep_xy_m``, ``spacing_m``). Volumes shrink as the UAV
    reports progress: the climb is freed once it is ``release_radius_m`` away (``release``), the flight becomes
    the zone at its site once it is down (``end_transit``).

    - **Layers**: a flight's lateral leg flies at ``layer_base_m + k * spacing_m``, the lowest k >= 0 on which
      the whole flight fits; a flight goes higher only where it would pass another UAV. ``layer_base_m`` is
      ``base_m``, the highest work altitude of the finished wall, or, given ``start_base_m``, starts there and
      rises with the wall (:meth:`raise_base`, called by mission control as tasks are assigned) up to ``base_m``;
      a flight keeps the altitude it was given.
    - **Pads**: a UAV landed on its pad holds only the pad; it takes off with the column over it (:meth:`take_off`),
      so take-offs and landings from neighbouring pads are sequenced.
    - **Waiting**: when no layer fits because the site's column is not free (another UAV works or is about to
      come down there, or the :class:`SiteGate` says no), the UAV gets a *hold flight* to a hold point near the
      site, ``1.1 wait_radius_m`` (horizontally) from every zone and every site another UAV waits for, where it
      hovers at its layer until the rest of the flight fits. A UAV whose hold flight does not fit either hovers
      where it is and asks again.
    - **Order**: requests are served first come, first served: a flight may not come down within
      ``wait_radius_m`` of the site of a UAV that asked earlier and still waits.
    - **Liveness**: a hold point never blocks a climb out of a zone nor the site of a waiting UAV; a UAV waiting
      in a zone can always leave it for a hold point once the flights in progress near it are down, and flights
      in progress need nothing more. So every waiting UAV waits for flights that end and for work that ends,
      never for another waiting UAV for ever (docs/safety.md).

    Args:
        radius_m: two zones never closer than this horizontally (the blueprint's clearance r_c); hold points
            this far from zones and waited sites.
        base_m: altitude of layer 0 over the finished wall (None: no airspace rules: every request is granted,
            with no layer); the zones over the homes reach it (a UAV takes off there up to its layer).
        spacing_m: vertical distance between layers; two volumes this far apart vertically never conflict.
        homes: each UAV's home (its pad): it starts landed there, holding only the pad; it takes off once
            :meth:`take_off` gave it the column over the pad, and holds the pad again once :meth:`landed`.
        sep_xy_m: horizontal separation between volumes (the 1 m target plus the horizontal tracking error).
        start_base_m: altitude of layer 0 at the start (e.g. the cruise altitude), raised by :meth:`raise_base`
            (None: ``base_m`` throughout).
        pad_separation_m: how close (centre to centre) another UAV may come to a landed one
            (:func:`masonry.separation.pad_separation_m`: the airframe's span plus a margin).
        gate: asked before a flight down to a site is granted, and told when it is (:class:`SiteGate`); call
            :meth:`touch` when its answers may have changed.
        fence: the site's geofence (None: none): no flight or hold flight is granted with a volume outside it
            (:mod:`masonry.mission.fence`), and a flight no layer can fly inside it is answered with the reason
            (``Grant.refused``).
    """

    def raise_base(self, altitude_m: float) -> None:
        """The wall may now reach ``altitude_m`` (a work altitude, :func:`task_work_altitude_m`): layer 0 of the
        flights granted from now on is at least that high (never above ``base_m``, never lower than it was).

        Flights already granted keep their altitudes: their volumes are reserved, and whatever is worked under
        them (the work that could raise the wall) needs a zone that must keep clear of them first.
        """
        if self.base_m is None or self.layer_base_m is None:
            return
        z = min(self.base_m, float(altitude_m))
        if z > self.layer_base_m:
            self.layer_base_m = z
            self._version += 1

    # -- what is reserved ---------------------------------------------------------------------------------------
    @property
    def release_radius_m(self) -> float:
        """A UAV frees the climb of its flight once this far (horizontally) from where it set off."""
        return self.sep_xy_m

    @property
    def held(self) -> dict[str, tuple[Vec3, ...]]:
        """UAV -> the site it holds: the one it flies to, or the one it works at."""
        return airspace_queries.held_sites(self)

    @property
    def layers(self) -> dict[str, int]:
        """UAV -> layer index of its flight in progress (granted, or to its hold point)."""
        return airspace_queries.flight_layers(self)

    def conflicts(self) -> list[tuple[str, str]]:
        """Pairs of UAVs whose volumes conflict now: always empty (the invariant the tests check)."""
        return airspace_queries.conflicting_pairs(self)

    def blockers(self, uav: str) -> list[tuple[str, str]]:
        """Who is in the way of what ``uav`` waits for (:func:`masonry.mission.airspace_queries.blockers`)."""
        return airspace_queries.blockers(self, uav)

    @property
    def waiting(self) -> tuple[str, ...]:
        """UAVs waiting for their flight, in request order."""
        return tuple(uav for uav, _u in self.waiting_records())

    def phase(self, uav: str) -> Phase:
        """Where ``uav`` is in the transit protocol (a UAV holding nothing is ``PARKED``)."""
        u = self.records.get(uav)
        return Phase.PARKED if u is None else u.phase

    def volumes(self, uav: str) -> tuple[Volume, ...]:
        """The volumes ``uav`` holds now."""
        u = self.records.get(uav)
        return () if u is None else tuple(u.volumes)

    def reserved_at(self, uav: str, t_s: float) -> Sequence[Volume]:
        """The volumes ``uav`` holds now, whatever ``t_s`` (:class:`~masonry.mission.envelope.ReservedSpace`): its
        record's own list, not a copy (the envelope watch reads it after every physics step)."""
        u = self.records.get(uav)
        return () if u is None else u.volumes

    def layer_m(self, uav: str) -> float | None:
        """Altitude of ``uav``'s flight in progress (None: none, or no layers)."""
        if self.base_m is None:
            return None
        u = self.records.get(uav)
        if u is None:
            return None
        if u.flight is not None:
            return u.flight.layer_m
        return None if u.hold is None else u.hold.layer_m

    # -- the protocol -----------------------------------------------------------------------------------------
    def request(
        self,
        uav: str,
        site_m: Vec3,
        now_s: float,
        position_m: Vec3 | None = None,
        top_m: float | None = None,
        to_m: Vec3 | None = None,
    ) -> Grant:
        """``uav`` (now at ``position_m``) sets off for ``site_m``, where it will work up to ``top_m`` (and along
        to ``to_m``: an adhesion UAV sprays from its site to there).

        A repeated request (same site) gets the same answer unless something changed, and keeps its place in the
        queue; one for another site replaces the UAV's pending one (its volumes stay until the new flight is
        granted: it is still where they are). The decision: :mod:`masonry.mission.airspace_requests`.
        """
        return airspace_requests.request(self, uav, site_m, now_s, position_m, top_m, to_m)

    def grant(self, now_s: float) -> list[Grant]:
        """Answer waiting UAVs, in request order, whose answer changed (a flight granted, or a hold flight)."""
        out: list[Grant] = []
        for uav, u in self.waiting_records():
            if u.seen_version == self._version:
                continue
            before = u.answer
            g = airspace_requests.evaluate(self, uav, u, now_s)
            if g.granted or (
                g.hold_m is not None
                and (before is None or (before.hold_m, before.layer_m) != (g.hold_m, g.layer_m))
            ):
                out.append(g)
        return out

    def end_transit(self, uav: str) -> None:
        """``uav``'s flight came down at its site: it holds the zone there now (:mod:`~masonry.mission.airspace_progress`)."""
        airspace_progress.end_transit(self, uav)

    def asked_for(self, uav: str) -> Vec3 | None:
        """The site ``uav`` waits to fly to (None: it waits for nothing)."""
        u = self.records.get(uav)
        return None if u is None or u.request is None else u.request.site

    def can_take_off(self, uav: str) -> bool:
        """``uav`` may take off now (:func:`masonry.mission.airspace_ground.can_take_off`)."""
        return airspace_ground.can_take_off(self, uav)

    def take_off(self, uav: str) -> bool:
        """``uav``, landed on its pad, is about to take off (:func:`masonry.mission.airspace_ground.take_off`)."""
        return airspace_ground.take_off(self, uav)

    def landed(self, uav: str, position_m: Vec3) -> bool:
        """``uav`` says it is on the ground at ``position_m`` (:func:`masonry.mission.airspace_ground.landed`)."""
        return airspace_ground.landed(self, uav, position_m)

    def rejoined(
        self,
        uav: str,
        position_m: Vec3 | None,
        way_home: tuple[float | None, Vec3 | None] | None = None,
    ) -> bool:
        """``uav``, out of the mission, is heard again (:func:`masonry.mission.airspace_ground.rejoined`)."""
        return airspace_ground.rejoined(self, uav, position_m, way_home)

    def silent(self, uav: str, position_m: Vec3, layer_m: float | None, via_m: Vec3 | None = None) -> float:
        """``uav`` fell silent in the air (:func:`masonry.mission.airspace_ground.silent`): the way home's length."""
        return airspace_ground.silent(self, uav, position_m, layer_m, via_m)

    def release(self, uav: str, site_m: Vec3 | None = None) -> None:
        """``uav`` is ``release_radius_m`` away from where it was at ``site_m`` (its climb there is over), or gave
        up asking for it; None: it is out of the mission (on the ground or fallen): everything is freed."""
        airspace_progress.release(self, uav, site_m)

    def progress(self, uav: str, position_m: Vec3) -> None:
        """``uav`` reports where it is: the part of its flight behind it is freed
        (:func:`masonry.mission.airspace_progress.progress`)."""
        airspace_progress.progress(self, uav, position_m)


__all__ = [
    "AT_HOLD_M",
    "DEFAULT_LAYER_SPACING_M",
    "HOVER_SLACK_M",
    "ON_PAD_XY_M",
    "ON_PAD_Z_M",
    "SNAP_M",
    "STOP_M",
    "TRACK_M",
    "ColumnClearance",
    "Grant",
    "Phase",
    "SiteGate",
    "Volume",
    "layer_base_m",
    "task_work_altitude_m",
    "transit_layers_m",
    "volumes_conflict",
    "work_altitude_m",
]
