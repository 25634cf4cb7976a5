"""Airspace separation between UAVs: reserved volumes, handed out by mission control at run time.

The paper's conflict graph G^c keeps the task *locations* r_c apart; it says nothing about the flights between
them, the shared pallet or the pads. :class:`ColumnClearance` closes that gap (docs/safety.md). The state
machines fly exactly its shapes: climb (or descend) vertically where they are, fly straight at the layer, come
down vertically over the site (``masonry.fsm``). Mission control runs the rules, so they work the same in-process
and across Zenoh (messages ``clearance-request`` / ``clearance``). Everything here is pure (no I/O, no clock).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from masonry.geofence import Site
from masonry.mission import airspace_ground, airspace_queries, airspace_requests
from masonry.mission.airspace_ground import ON_PAD_XY_M, ON_PAD_Z_M
from masonry.mission.airspace_state import (
    Grant,
    Phase,
    UavAirspace,
)
from masonry.mission.altitudes import layer_base_m, task_work_altitude_m, transit_layers_m, work_altitude_m
from masonry.mission.fence import volumes_in_fence
from masonry.mission.sites import SiteGate
from masonry.mission.volumes import (
    HOVER_SLACK_M,
    STOP_M,
    TRACK_M,
    XY,
    Vec3,
    Volume,
    ahead_of,
    column,
    flight_volumes,
    same_site,
    volumes_clear,
    volumes_conflict,
)
from masonry.mission.volumes import point_segment_m as _point_segment_m  # noqa: F401 - the tests' name
from masonry.separation import LAYER_SPACING_M, SEPARATION_XY_M, pad_separation_m, zone_slack_m

#: Vertical distance between two transit layers: the 1 m separation target plus tracking error and gusts.
DEFAULT_LAYER_SPACING_M = LAYER_SPACING_M

#: A UAV reported within this of a layer's altitude is at the layer (hover noise). UAVs come to rest where they
#: stop before they ask (``masonry.fsm``), so a UAV reported farther from a layer is where it says: a UAV at rest
#: 0.11 m over layer 0 after stopping a climb, counted at the layer, was 0.11 m outside its climb.
SNAP_M = 0.05

#: A UAV within this of its hold point (horizontally) hovers there: the state machines count a leg as done
#: within 0.08 m (``UavConfig.arrive_tolerance_m``), and only then read the rest of their flight.
AT_HOLD_M = 0.1


class ColumnClearance:
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

    def __init__(
        self,
        radius_m: float,
        base_m: float | None = None,
        spacing_m: float = DEFAULT_LAYER_SPACING_M,
        homes: Mapping[str, Vec3] | None = None,
        sep_xy_m: float = SEPARATION_XY_M,
        start_base_m: float | None = None,
        pad_separation_m: float = pad_separation_m(),
        gate: SiteGate | None = None,
        fence: Site | None = None,
    ) -> None:
        if not (radius_m >= 0.0 and math.isfinite(radius_m)):
            raise ValueError(f"column radius must be a finite number >= 0, got {radius_m!r}")
        if not (spacing_m > 0.0 and math.isfinite(spacing_m)):
            raise ValueError(f"layer spacing must be a finite number > 0, got {spacing_m!r}")
        if not (sep_xy_m > 0.0 and math.isfinite(sep_xy_m)):
            raise ValueError(f"separation must be a finite number > 0, got {sep_xy_m!r}")
        if not (0.0 < pad_separation_m <= sep_xy_m and math.isfinite(pad_separation_m)):
            raise ValueError(f"pad separation must be in (0, {sep_xy_m}] m, got {pad_separation_m!r}")
        self.radius_m = float(radius_m)
        self.base_m = None if base_m is None else float(base_m)
        #: altitude of layer 0 now: from ``start_base_m`` up to ``base_m`` as the wall rises (:meth:`raise_base`)
        self.layer_base_m = self.base_m
        if self.base_m is not None and start_base_m is not None:
            self.layer_base_m = min(self.base_m, float(start_base_m))
        self.spacing_m = float(spacing_m)
        self.sep_xy_m = float(sep_xy_m)
        #: horizontal slack of a zone: two zones are ``radius_m`` apart
        self.zone_slack_m = zone_slack_m(self.radius_m, self.sep_xy_m)
        #: how far a waiting UAV keeps from the sites others wait for (first come, first served) and hold points
        #: from everyone's sites: two zones' separation, r_c, or more when r_c is below the separation (a hold
        #: hover 1.1 r_c = 0.94 m from another's site at r_c 0.85 m blocked its descent, and that one's hold
        #: hover blocked this one's: two UAVs waited at their hold points for each other for ever)
        self.wait_radius_m = max(self.radius_m, self.sep_xy_m + 2.0 * self.zone_slack_m)
        #: a pad's (negative) slack: another volume needs only ``pad_separation_m`` from it, not ``sep_xy_m``
        self.pad_slack_m = float(pad_separation_m) - self.sep_xy_m - 1e-6
        self.max_layers = 12
        self.gate = gate
        self.fence = fence
        self.fence_refusals: dict[str, str] = {}  # a UAV's request no layer can fly inside the fence: why
        #: UAVs whose flight home is held back (mission/linger.py) -> what their hold point keeps clear of
        self.lingering: dict[str, tuple[tuple[XY, XY], ...]] = {}
        #: lingering UAVs just handed a task at their spot: their flight home is not granted until they ask again
        self.handed_task: set[str] = set()
        self.records: dict[str, UavAirspace] = {}
        self.homes: dict[str, Vec3] = {
            u: (float(h[0]), float(h[1]), float(h[2])) for u, h in (homes or {}).items()
        }
        self.seq = 0  # requests made so far (their order)
        self._version = 0
        self.granted_count = 0
        self.held_back = 0  # hold flights given (a UAV sent to wait near its site)
        self.refused = 0  # requests answered "hover where you are"
        self.wait_s = 0.0  # summed time between request and grant
        self.max_wait_s = 0.0
        self.layer_counts: dict[int, int] = {}  # granted flights per layer index
        if self.base_m is not None:
            for uav in self.homes:
                self.set_pad(uav)

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
        """``uav``'s flight came down at its site: it holds the zone there now."""
        u = self.records.get(uav)
        if u is None or u.flight is None:
            return
        f = u.flight
        u.flight, u.origin, u.phase = None, None, Phase.PARKED
        self.set_zone(uav, f.site, f.top_m, f.to)

    def asked_for(self, uav: str) -> Vec3 | None:
        """The site ``uav`` waits to fly to (None: it waits for nothing)."""
        u = self.records.get(uav)
        return None if u is None or u.request is None else u.request.site

    @property
    def version(self) -> int:
        """Changes whenever a reservation changes (a take-off refused before may fit after it changed)."""
        return self._version

    def touch(self) -> None:
        """Something outside the reservations changed (the :class:`SiteGate`'s answers): look at every waiting
        request again."""
        self._version += 1

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
        if site_m is None:
            self.records.pop(uav, None)
            self._version += 1
            return
        u = self.records.get(uav)
        if u is None:
            return
        if u.request is not None and same_site(u.request.site, site_m) and u.phase is Phase.ASKING:
            u.request, u.phase = None, Phase.PARKED  # given up before anything was granted
            self._version += 1
            return
        if u.origin is not None and same_site(u.origin, site_m):
            u.origin = None
            kept = [v for v in u.volumes if v.kind != "climb"]
            if len(kept) != len(u.volumes):
                u.volumes = kept
                self._version += 1

    def progress(self, uav: str, position_m: Vec3) -> None:
        """``uav`` reports where it is: the part of its flight behind it is freed.

        Only a position on the flight's lateral leg (at its layer, within ``TRACK_M`` of the leg) or in the
        descent over its site counts; anything else (a report sent before the flight was granted, say) is ignored.
        A UAV flies its legs forward from rest to rest, so what lies more than ``TRACK_M`` behind it is left.
        """
        u = self.records.get(uav)
        vols = None if u is None else u.volumes
        if not vols or u is None or self.base_m is None:
            return
        x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
        h = u.hold
        if (
            u.phase is Phase.TO_HOLD
            and h is not None
            and math.hypot(x - h.point_m[0], y - h.point_m[1]) < AT_HOLD_M
            and abs(z - h.layer_m) < SNAP_M  # at the layer: it may still be coming down to it from above
        ):
            self.arrive_at_hold(u)  # it hovers at its hold point
            return
        kept = ahead_of(vols, x, y, z)
        if kept is None:
            return
        if len(kept) != len(vols) or any(k is not v for k, v in zip(kept, vols)):
            u.volumes = kept
            self._version += 1

    # -- internals --------------------------------------------------------------------------------------------
    def alt(self, k: int) -> float:
        assert self.layer_base_m is not None
        return self.layer_base_m + k * self.spacing_m

    def snap(self, z: float) -> float:
        """A UAV hovering within ``SNAP_M`` of a layer is at that layer (its tracking error, not a place)."""
        assert self.layer_base_m is not None
        j = round((z - self.layer_base_m) / self.spacing_m)
        if j >= 0 and abs(z - self.alt(j)) < SNAP_M:
            return self.alt(j)
        return z

    def conflict(self, p: Volume, q: Volume) -> bool:
        return volumes_conflict(p, q, self.sep_xy_m, self.spacing_m - 1e-9)

    def zone_column(self, site: Vec3, top: float, to: XY | None = None) -> Volume:
        return column(site, top, to, self.zone_slack_m)

    def set_zone(self, uav: str, site: Vec3, top: float, to: XY | None = None) -> None:
        u = self.record(uav)
        u.zone = site
        if self.is_home(uav, site):
            u.volumes = [self.home_column(uav, top)]
        else:
            u.volumes = [self.zone_column(site, top, to)]
        if u.phase is Phase.LANDED:
            u.phase = Phase.PARKED
        self._version += 1

    def is_home(self, uav: str, site: Vec3) -> bool:
        home = self.homes.get(uav)
        return home is not None and same_site(home, site)

    def home_top_m(self) -> float:
        assert self.base_m is not None
        return self.base_m

    def home_column(self, uav: str, top: float = 0.0) -> Volume:
        """The column over ``uav``'s pad, up to its transit altitude: no work there, so no work slack (a UAV
        taking off or landing keeps ``pad_separation_m`` from a neighbour landed on its pad)."""
        home = self.homes[uav]
        return column(home, max(top, self.home_top_m()), None, 0.0)

    def set_pad(self, uav: str) -> None:
        """``uav`` is on its pad: it holds only the pad (others keep ``pad_separation_m`` from it)."""
        u = self.record(uav)
        home = self.homes[uav]
        xy = (home[0], home[1])
        u.phase, u.zone, u.origin, u.flight, u.hold = Phase.LANDED, None, None, None, None
        u.volumes = [Volume(xy, xy, home[2], home[2], self.pad_slack_m, "pad")]
        self._version += 1

    def free(self, uav: str, vols: list[Volume]) -> bool:
        """No volume of ``vols`` conflicts with another UAV's (:func:`volumes_clear`)."""
        others = [q for other, u in self.records.items() if other != uav for q in u.volumes]
        return volumes_clear(vols, others, self.sep_xy_m, self.spacing_m - 1e-9)

    def fits(self, uav: str, vols: list[Volume]) -> bool:
        """``vols`` keep inside the fence (if any) and clear of every other UAV's."""
        return (self.fence is None or volumes_in_fence(self.fence, vols)) and self.free(uav, vols)

    def record(self, uav: str) -> UavAirspace:
        """``uav``'s record (a new one, holding nothing, for a UAV not seen since it left)."""
        u = self.records.get(uav)
        if u is None:
            u = self.records[uav] = UavAirspace()
        return u

    def waiting_records(self) -> list[tuple[str, UavAirspace]]:
        """The UAVs with a request, in request order."""
        return sorted(
            ((n, u) for n, u in self.records.items() if u.request is not None),
            key=lambda nu: nu[1].request.seq,  # type: ignore[union-attr]
        )

    def flight_volumes_at(
        self,
        start: Vec3,
        target: Vec3 | None,
        top: float,
        k: int,
        hold: XY | None,
        to: XY | None = None,
        *,
        home: bool = False,
    ) -> list[Volume]:
        """Climb at ``start`` to layer ``k``, leg to the target (or the hold point), its column (or hover; the
        column over a UAV's own pad, ``home``, has no work slack)."""
        vols = flight_volumes(
            (start[0], start[1]), self.snap(start[2]), self.alt(k), target, top, hold, to, self.zone_slack_m
        )
        if home and target is not None and hold is None:
            vols[-1] = dataclasses.replace(vols[-1], slack_m=0.0)
        return vols

    def take(self, u: UavAirspace, vols: list[Volume]) -> None:
        # a climb from mid-air (a UAV turned back) is kept until it is down
        u.origin, u.zone = u.zone, None
        u.volumes = vols
        self._version += 1

    def arrive_at_hold(self, u: UavAirspace) -> None:
        """It hovers at its hold point: only the hover is its now."""
        assert u.hold is not None
        u.phase = Phase.AT_HOLD
        u.origin = None
        hxy = (u.hold.point_m[0], u.hold.point_m[1])
        alt = u.hold.layer_m
        # (a hover widened for a fast leg there stays so: a heartbeat may say it is there before it overshoots)
        end = u.volumes[-1] if u.volumes else None
        slack = end.slack_m if end is not None and end.kind == "hover" else self.zone_slack_m
        u.volumes = [Volume(hxy, hxy, alt, alt, max(slack, self.zone_slack_m), "hover")]
        self._version += 1


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
