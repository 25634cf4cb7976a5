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

from masonry.geofence import AIRSPACE_MARGIN_M, Site
from masonry.mission.airspace_state import (
    FlightRequest,
    Grant,
    GrantedFlight,
    HoldFlight,
    Phase,
    UavAirspace,
    hold_candidates,
)
from masonry.mission.altitudes import layer_base_m, task_work_altitude_m, transit_layers_m, work_altitude_m
from masonry.mission.fence import flight_fence_problem, volumes_in_fence
from masonry.mission.sites import SiteGate, enter_ungoverned
from masonry.mission.volumes import (
    HOVER_SLACK_M,
    STOP_M,
    TRACK_M,
    XY,
    Vec3,
    Volume,
    ahead_of,
    column,
    contains,
    flight_volumes,
    stopped_at,
    volumes_clear,
    volumes_conflict,
)
from masonry.mission.volumes import point_segment_m as _point_segment_m  # noqa: F401 - the tests' name
from masonry.separation import LAYER_SPACING_M, SEPARATION_XY_M, pad_separation_m, zone_slack_m

#: Vertical distance between two transit layers: the 1 m separation target plus tracking error and gusts.
DEFAULT_LAYER_SPACING_M = LAYER_SPACING_M

#: A UAV reported this close to its home (horizontally) and this low is on its pad.
ON_PAD_XY_M = 0.3
ON_PAD_Z_M = 0.3


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
        self._fence_refusals: dict[str, str] = {}  # a UAV's request no layer can fly inside the fence: why
        self._uavs: dict[str, UavAirspace] = {}
        self._homes: dict[str, Vec3] = {
            u: (float(h[0]), float(h[1]), float(h[2])) for u, h in (homes or {}).items()
        }
        self._seq = 0  # requests made so far (their order)
        self._version = 0
        self.granted_count = 0
        self.held_back = 0  # hold flights given (a UAV sent to wait near its site)
        self.refused = 0  # requests answered "hover where you are"
        self.wait_s = 0.0  # summed time between request and grant
        self.max_wait_s = 0.0
        self.layer_counts: dict[int, int] = {}  # granted flights per layer index
        if self.base_m is not None:
            for uav in self._homes:
                self._set_pad(uav)

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
        out: dict[str, tuple[Vec3, ...]] = {}
        for uav, u in self._uavs.items():
            if u.flight is not None:
                out[uav] = (u.flight.site,)
            elif u.zone is not None and u.zone != self._homes.get(uav):
                out[uav] = (u.zone,)
        return out

    @property
    def waiting(self) -> tuple[str, ...]:
        """UAVs waiting for their flight, in request order."""
        return tuple(uav for uav, _u in self._waiting())

    @property
    def layers(self) -> dict[str, int]:
        """UAV -> layer index of its flight in progress (granted, or to its hold point)."""
        return {
            uav: u.flight.layer if u.flight is not None else u.hold.layer  # type: ignore[union-attr]
            for uav, u in self._uavs.items()
            if u.flight is not None or u.hold is not None
        }

    def phase(self, uav: str) -> Phase:
        """Where ``uav`` is in the transit protocol (a UAV holding nothing is ``PARKED``)."""
        u = self._uavs.get(uav)
        return Phase.PARKED if u is None else u.phase

    def volumes(self, uav: str) -> tuple[Volume, ...]:
        """The volumes ``uav`` holds now."""
        u = self._uavs.get(uav)
        return () if u is None else tuple(u.volumes)

    def layer_m(self, uav: str) -> float | None:
        """Altitude of ``uav``'s flight in progress (None: none, or no layers)."""
        if self.base_m is None:
            return None
        u = self._uavs.get(uav)
        if u is None:
            return None
        if u.flight is not None:
            return u.flight.layer_m
        return None if u.hold is None else u.hold.layer_m

    def conflicts(self) -> list[tuple[str, str]]:
        """Pairs of UAVs whose volumes conflict now: always empty (the invariant the tests check)."""
        names = list(self._uavs)
        out = []
        for i, u in enumerate(names):
            for w in names[i + 1 :]:
                if any(
                    volumes_conflict(p, q, self.sep_xy_m, self.spacing_m - 1e-9)
                    for p in self._uavs[u].volumes
                    for q in self._uavs[w].volumes
                ):
                    out.append((u, w))
        return out

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
        granted: it is still where they are).
        """
        site = (float(site_m[0]), float(site_m[1]), float(site_m[2]))
        top = max(site[2], float(top_m) if top_m is not None else site[2])
        if self.base_m is None:  # no airspace rules: only the site gate may hold the flight back
            granted = enter_ungoverned(self.gate, uav, site, now_s)
            self.granted_count += granted
            self.refused += not granted
            return Grant(uav, site, granted)
        u = self._uav(uav)
        pos = (
            None if position_m is None else (float(position_m[0]), float(position_m[1]), float(position_m[2]))
        )
        if u.flight is not None:
            if _same(u.flight.site, site) and (pos is None or contains(u.volumes, *pos)):
                return Grant(uav, site, layer_m=u.flight.layer_m)
            # turned back for another site, or asks again from outside the flight it was given (a retry after a
            # failsafe flew it off): it keeps the volumes of that flight until a fresh one is granted
            u.flight = None
            u.phase = Phase.PARKED
        w = u.request
        if w is not None and _same(w.site, site):
            if pos is not None and u.phase is Phase.ASKING and pos != w.position:
                u.request = dataclasses.replace(w, position=pos)
                u.seen_version = -1  # where it asks from changed: look again
            return self._evaluate(uav, u, now_s)
        if pos is not None and u.zone is None:
            self._hover_where(uav, pos)  # it turned back mid-flight: it stays where it is until answered
        to = None
        if to_m is not None and math.hypot(float(to_m[0]) - site[0], float(to_m[1]) - site[1]) > 1e-6:
            to = (float(to_m[0]), float(to_m[1]))
        self._seq += 1
        u.request, u.hold, u.phase = FlightRequest(site, top, pos, now_s, self._seq, to), None, Phase.ASKING
        self._check_fence(uav, u.request)
        u.seen_version, u.answer = -1, None
        self._version += 1  # the queue changed: answers of those behind it may change
        return self._evaluate(uav, u, now_s)

    def grant(self, now_s: float) -> list[Grant]:
        """Answer waiting UAVs, in request order, whose answer changed (a flight granted, or a hold flight)."""
        out: list[Grant] = []
        for uav, u in self._waiting():
            if u.seen_version == self._version:
                continue
            before = u.answer
            g = self._evaluate(uav, u, now_s)
            if g.granted or (g.hold_m is not None and (before is None or before.hold_m is None)):
                out.append(g)
        return out

    def end_transit(self, uav: str) -> None:
        """``uav``'s flight came down at its site: it holds the zone there now."""
        u = self._uavs.get(uav)
        if u is None or u.flight is None:
            return
        f = u.flight
        u.flight, u.origin, u.phase = None, None, Phase.PARKED
        self._set_zone(uav, f.site, f.top_m, f.to)

    def asked_for(self, uav: str) -> Vec3 | None:
        """The site ``uav`` waits to fly to (None: it waits for nothing)."""
        u = self._uavs.get(uav)
        return None if u is None or u.request is None else u.request.site

    def blockers(self, uav: str) -> list[tuple[str, str]]:
        """Who is in the way of what ``uav`` waits for, and with what: ``(other UAV, volume kind)`` for every
        other UAV whose volumes conflict with its flight at the lowest layer (or, landed, with its take-off
        column), and ``(other, "earlier-request")`` for one that asked first for a site within the radius.
        Empty: nothing blocks it (it is not waiting, or its answer is on the way). For the stall report."""
        u = self._uavs.get(uav)
        if self.base_m is None or u is None:
            return []
        out: list[tuple[str, str]] = []
        if u.phase is Phase.LANDED:
            wanted = [self._home_column(uav)]
        elif u.request is not None:
            w = u.request
            out = [
                (other, "earlier-request")
                for other, o in self._waiting()
                if other != uav
                and o.request is not None
                and o.request.seq < w.seq
                and math.hypot(o.request.site[0] - w.site[0], o.request.site[1] - w.site[1])
                < self.wait_radius_m
            ]
            if u.phase is Phase.AT_HOLD and u.hold is not None:
                start = (u.hold.point_m[0], u.hold.point_m[1], u.hold.layer_m)
            else:
                start = w.position if w.position is not None else w.site
            home = self._is_home(uav, w.site)
            wanted = self._flight_volumes(start, w.site, w.top_m, 0, None, w.to, home=home)
        else:
            return []
        for other, o in self._uavs.items():
            if other == uav:
                continue
            kind = next((q.kind for q in o.volumes for v in wanted if self._conflict(v, q)), None)
            if kind is not None:
                out.append((other, kind))
        return out

    @property
    def version(self) -> int:
        """Changes whenever a reservation changes (a take-off refused before may fit after it changed)."""
        return self._version

    def touch(self) -> None:
        """Something outside the reservations changed (the :class:`SiteGate`'s answers): look at every waiting
        request again."""
        self._version += 1

    def can_take_off(self, uav: str) -> bool:
        """``uav`` may take off now: it holds more than its pad already, or the column over its pad is free."""
        u = self._uavs.get(uav)
        if self.base_m is None or u is None or u.phase is not Phase.LANDED:
            return True
        return self._free(uav, [self._home_column(uav)])

    def take_off(self, uav: str) -> bool:
        """``uav``, landed on its pad, is about to take off: it holds the column over its pad up to the transit
        altitude, if that is free (True), else it stays on its pad (False: ask again once :attr:`version`
        changed). A UAV that is not landed already holds what it needs (True)."""
        if not self.can_take_off(uav):
            return False
        u = self._uavs.get(uav)
        if u is not None and u.phase is Phase.LANDED:
            self._set_zone(uav, self._homes[uav], self._home_top_m())
        return True

    def landed(self, uav: str, position_m: Vec3) -> bool:
        """``uav`` says it is on the ground at ``position_m``, done flying: if that is on its pad, it holds only
        the pad from now on (True). A UAV whose flight home is still reserved (its ``arrived`` was lost) lands
        out of it too, and so does one holding only where it was last seen (a zone, nothing granted)."""
        home = self._homes.get(uav)
        u = self._uavs.get(uav)
        if self.base_m is None or home is None or u is None or u.phase is Phase.LANDED:
            return False
        x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
        if math.hypot(x - home[0], y - home[1]) > ON_PAD_XY_M or z - home[2] > ON_PAD_Z_M:
            return False
        at_home = u.zone is not None and _same(u.zone, home)
        flying_home = u.flight is not None and _same(u.flight.site, home)
        # nothing granted in flight: what it holds is where it was last seen (heard again while it flew home on
        # its own, cut off past LAST_RESORT_S: the column where it was heard); it is on its pad now
        seen_elsewhere = u.flight is None and u.hold is None
        if u.request is not None or not (at_home or flying_home or seen_elsewhere):
            return False
        self._set_pad(uav)
        return True

    def rejoined(
        self,
        uav: str,
        position_m: Vec3 | None,
        way_home: tuple[float | None, Vec3 | None] | None = None,
    ) -> bool:
        """``uav``, taken out of the mission (:meth:`release` with no site), is heard again at ``position_m``: on
        its pad it holds the pad again and takes off like the others; in the air (it hovers where it stopped,
        cut off, and asks for its flight home) it holds the column where it is, up to the transit altitude,
        as after a take-off there, and asks from there; with ``way_home`` (it says it is flying home, or putting
        a brick back, maybe on its own) also that way (:meth:`silent`). False: it is down away from its pad (not back yet);
        with no position known it is taken back holding nothing."""
        home = self._homes.get(uav)
        if self.base_m is None or home is None or position_m is None:
            return True
        x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
        on_pad = math.hypot(x - home[0], y - home[1]) <= ON_PAD_XY_M
        if z - home[2] <= ON_PAD_Z_M:
            if not on_pad:
                return False
            self._set_pad(uav)  # (a silent UAV landed kept the column over its pad too: :meth:`silent`)
            return True
        u = self._uav(uav)
        # what it was granted before it fell silent is over (its `arrived` would end the old flight at its site)
        u.flight, u.hold, u.request, u.origin, u.phase = None, None, None, None, Phase.PARKED
        self._set_zone(uav, (x, y, home[2]), max(z, self._home_top_m()))
        if way_home is not None:
            # it is flying home on its own (cut off past LAST_RESORT_S, it asks nobody until it is down): the
            # rest of that way stays its own (``way_home``: its fallback layer and the pickup it calls at first)
            u.volumes = [*u.volumes, *self._way_home(uav, (x, y, z), way_home[0], way_home[1])[0]]
        return True

    def silent(self, uav: str, position_m: Vec3, layer_m: float | None, via_m: Vec3 | None = None) -> float:
        """``uav`` fell silent in the air at ``position_m``: besides what it holds it keeps the way home it flies on
        its own once mission control has been silent for ``LAST_RESORT_S`` (its machine's route without an
        airspace): the climb or descent where it is to ``layer_m`` (its fixed fallback layer; None: the altitude
        it is at), the leg there to above its pad, and its pad's column; with ``via_m`` (a brick's pickup: it
        puts the brick back first) through that site's column. Returns the way's length in metres."""
        u = self._uavs.get(uav)
        if u is None or uav not in self._homes:
            return 0.0
        way, length_m = self._way_home(uav, position_m, layer_m, via_m)
        u.volumes = [*u.volumes, *way]
        self._version += 1
        return length_m

    def _way_home(
        self, uav: str, position_m: Vec3, layer_m: float | None, via_m: Vec3 | None
    ) -> tuple[list[Volume], float]:
        """The volumes of the flight home without an airspace (see :meth:`silent`), and its length."""
        home = self._homes[uav]
        x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
        alt = float(layer_m) if layer_m is not None else z
        top = self._home_top_m()
        if via_m is None:
            way = flight_volumes((x, y), z, alt, home, top, None, None, 0.0)
            return way, math.hypot(home[0] - x, home[1] - y) + abs(alt - z) + abs(alt - home[2])
        via = (float(via_m[0]), float(via_m[1]), float(via_m[2]))
        first = flight_volumes((x, y), z, alt, via, top, None, None, 0.0)
        then = flight_volumes((via[0], via[1]), via[2], alt, home, top, None, None, 0.0)
        length_m = (
            math.hypot(via[0] - x, via[1] - y)
            + math.hypot(home[0] - via[0], home[1] - via[1])
            + abs(alt - z)
            + 2.0 * abs(alt - via[2])
            + abs(alt - home[2])
        )
        return [*first, *then], length_m

    def release(self, uav: str, site_m: Vec3 | None = None) -> None:
        """``uav`` is ``release_radius_m`` away from where it was at ``site_m`` (its climb there is over), or gave
        up asking for it; None: it is out of the mission (on the ground or fallen): everything is freed."""
        if site_m is None:
            self._uavs.pop(uav, None)
            self._version += 1
            return
        u = self._uavs.get(uav)
        if u is None:
            return
        if u.request is not None and _same(u.request.site, site_m) and u.phase is Phase.ASKING:
            u.request, u.phase = None, Phase.PARKED  # given up before anything was granted
            self._version += 1
            return
        if u.origin is not None and _same(u.origin, site_m):
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
        u = self._uavs.get(uav)
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
            self._arrive_at_hold(u)  # it hovers at its hold point
            return
        kept = ahead_of(vols, x, y, z)
        if kept is None:
            return
        if len(kept) != len(vols) or any(k is not v for k, v in zip(kept, vols)):
            u.volumes = kept
            self._version += 1

    # -- internals --------------------------------------------------------------------------------------------
    def _alt(self, k: int) -> float:
        assert self.layer_base_m is not None
        return self.layer_base_m + k * self.spacing_m

    def _snap(self, z: float) -> float:
        """A UAV hovering within ``SNAP_M`` of a layer is at that layer (its tracking error, not a place)."""
        assert self.layer_base_m is not None
        j = round((z - self.layer_base_m) / self.spacing_m)
        if j >= 0 and abs(z - self._alt(j)) < SNAP_M:
            return self._alt(j)
        return z

    def _conflict(self, p: Volume, q: Volume) -> bool:
        return volumes_conflict(p, q, self.sep_xy_m, self.spacing_m - 1e-9)

    def _column(self, site: Vec3, top: float, to: XY | None = None) -> Volume:
        return column(site, top, to, self.zone_slack_m)

    def _set_zone(self, uav: str, site: Vec3, top: float, to: XY | None = None) -> None:
        u = self._uav(uav)
        u.zone = site
        if self._is_home(uav, site):
            u.volumes = [self._home_column(uav, top)]
        else:
            u.volumes = [self._column(site, top, to)]
        if u.phase is Phase.LANDED:
            u.phase = Phase.PARKED
        self._version += 1

    def _is_home(self, uav: str, site: Vec3) -> bool:
        home = self._homes.get(uav)
        return home is not None and _same(home, site)

    def _home_top_m(self) -> float:
        assert self.base_m is not None
        return self.base_m

    def _home_column(self, uav: str, top: float = 0.0) -> Volume:
        """The column over ``uav``'s pad, up to its transit altitude: no work there, so no work slack (a UAV
        taking off or landing keeps ``pad_separation_m`` from a neighbour landed on its pad)."""
        home = self._homes[uav]
        return column(home, max(top, self._home_top_m()), None, 0.0)

    def _set_pad(self, uav: str) -> None:
        """``uav`` is on its pad: it holds only the pad (others keep ``pad_separation_m`` from it)."""
        u = self._uav(uav)
        home = self._homes[uav]
        xy = (home[0], home[1])
        u.phase, u.zone, u.origin, u.flight, u.hold = Phase.LANDED, None, None, None, None
        u.volumes = [Volume(xy, xy, home[2], home[2], self.pad_slack_m, "pad")]
        self._version += 1

    def _free(self, uav: str, vols: list[Volume]) -> bool:
        """No volume of ``vols`` conflicts with another UAV's (:func:`volumes_clear`)."""
        others = [q for other, u in self._uavs.items() if other != uav for q in u.volumes]
        return volumes_clear(vols, others, self.sep_xy_m, self.spacing_m - 1e-9)

    def _fits(self, uav: str, vols: list[Volume]) -> bool:
        """``vols`` keep inside the fence (if any) and clear of every other UAV's."""
        return (self.fence is None or volumes_in_fence(self.fence, vols)) and self._free(uav, vols)

    def _check_fence(self, uav: str, w: FlightRequest) -> None:
        """Note why ``uav``'s new request can never be flown inside the fence, if it cannot (at no layer)."""
        self._fence_refusals.pop(uav, None)
        if self.fence is None:
            return
        start = w.position if w.position is not None else w.site
        start = (start[0], start[1], self._snap(start[2]))
        layers = [self._alt(k) for k in range(self.max_layers)]
        problem = flight_fence_problem(self.fence, start, w.site, w.top_m, w.to, layers, self.zone_slack_m)
        if problem is not None:
            self._fence_refusals[uav] = problem

    def _uav(self, uav: str) -> UavAirspace:
        """``uav``'s record (a new one, holding nothing, for a UAV not seen since it left)."""
        u = self._uavs.get(uav)
        if u is None:
            u = self._uavs[uav] = UavAirspace()
        return u

    def _waiting(self) -> list[tuple[str, UavAirspace]]:
        """The UAVs with a request, in request order."""
        return sorted(
            ((n, u) for n, u in self._uavs.items() if u.request is not None),
            key=lambda nu: nu[1].request.seq,  # type: ignore[union-attr]
        )

    def _queued_before(self, seq: int) -> list[FlightRequest]:
        """The requests made before ``seq`` that wait for the airspace: one the :class:`SiteGate` holds back (its
        site is busy with conflicting work, or its prerequisites are not done) waits for work, not for the
        airspace, and keeps no one else from coming down near its site (else the two could wait for each other:
        an adhesion UAV waiting for the brick under its segment, whose UAV waited for the adhesion UAV's turn)."""
        gate = self.gate
        return [
            u.request
            for n, u in self._waiting()
            if u.request is not None
            and u.request.seq < seq
            and (gate is None or gate.may_enter(n, u.request.site))
        ]

    def _flight_volumes(
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
            (start[0], start[1]), self._snap(start[2]), self._alt(k), target, top, hold, to, self.zone_slack_m
        )
        if home and target is not None and hold is None:
            vols[-1] = dataclasses.replace(vols[-1], slack_m=0.0)
        return vols

    def _evaluate(self, uav: str, u: UavAirspace, now_s: float) -> Grant:
        """Grant ``uav``'s flight if it fits, else a hold flight, else "hover where you are"."""
        w = u.request
        assert w is not None
        if u.seen_version == self._version and u.answer is not None:
            return u.answer
        u.seen_version = self._version
        refused = self._fence_refusals.get(uav)
        if refused is not None and u.phase is Phase.ASKING:
            self.refused += 1
            u.answer = Grant(uav, w.site, False, refused=refused)
            return u.answer
        earlier = self._queued_before(w.seq)
        blocked_site = any(
            math.hypot(e.site[0] - w.site[0], e.site[1] - w.site[1]) < self.wait_radius_m for e in earlier
        ) or (self.gate is not None and not self.gate.may_enter(uav, w.site))
        if not blocked_site:
            home = self._is_home(uav, w.site)
            if u.phase is Phase.AT_HOLD:
                # hovering at its hold point (it said so): from there, to the lowest layer that fits now, over to
                # the site and down. Not before: a UAV flies its hold flight to the end before it reads another
                # answer, and one that never saw its hold answer (a later one came first) would fly straight.
                assert u.hold is not None
                hold = (u.hold.point_m[0], u.hold.point_m[1], u.hold.layer_m)
                for k in range(self.max_layers):
                    extra = self._flight_volumes(hold, w.site, w.top_m, k, None, w.to, home=home)
                    if self._fits(uav, extra):
                        u.volumes = u.volumes + extra
                        self._version += 1
                        return self._granted(uav, u, k, now_s)
            elif u.phase is Phase.ASKING:
                start = w.position if w.position is not None else w.site
                for k in range(self.max_layers):
                    vols = self._flight_volumes(start, w.site, w.top_m, k, None, w.to, home=home)
                    if self._fits(uav, vols):
                        self._take(u, vols)
                        return self._granted(uav, u, k, now_s)
        if u.phase is Phase.ASKING:
            g = self._hold_flight(uav, u)
            if g is not None:
                u.answer = g
                self.held_back += 1
                return g
            self.refused += 1
            u.answer = Grant(uav, w.site, False)
            return u.answer
        assert u.hold is not None
        u.answer = Grant(uav, w.site, False, u.hold.point_m, u.hold.layer_m)
        return u.answer

    def _take(self, u: UavAirspace, vols: list[Volume]) -> None:
        # a climb from mid-air (a UAV turned back) is kept until it is down
        u.origin, u.zone = u.zone, None
        u.volumes = vols
        self._version += 1

    def _granted(self, uav: str, u: UavAirspace, k: int, now_s: float) -> Grant:
        w = u.request
        assert w is not None
        u.flight = GrantedFlight(w.site, k, self._alt(k), w.top_m, w.to)
        u.request, u.hold, u.phase = None, None, Phase.FLYING
        waited = max(0.0, now_s - w.since_s)
        self.wait_s += waited
        self.max_wait_s = max(self.max_wait_s, waited)
        self.granted_count += 1
        self.layer_counts[k] = self.layer_counts.get(k, 0) + 1
        self._version += 1
        if self.gate is not None:
            self.gate.entered(uav, w.site, now_s)
        return Grant(uav, w.site, layer_m=self._alt(k))

    def _hold_flight(self, uav: str, u: UavAirspace) -> Grant | None:
        """A flight to a hold point near the site, at the lowest layer that fits (None: none fits now)."""
        w = u.request
        assert w is not None
        start = w.position if w.position is not None else w.site
        others = [o for n, o in self._uavs.items() if n != uav]
        pads = [(h[0], h[1]) for n, h in self._homes.items() if n != uav]
        waited = () if self.gate is None else self.gate.waited_on(uav)
        candidates = hold_candidates(w.site, others, self.wait_radius_m, pads, waited)
        if self.fence is not None:  # only hold points inside it (else near an edge all six could be outside)
            need = AIRSPACE_MARGIN_M + self.zone_slack_m
            candidates = [h for h in candidates if self.fence.contains(h[0], h[1], need)]
        for k in range(self.max_layers):
            for hold in candidates[:6]:
                vols = self._flight_volumes(start, None, w.top_m, k, (hold[0], hold[1]))
                if self._fits(uav, vols):
                    self._take(u, vols)
                    u.hold, u.phase = HoldFlight(hold, k, self._alt(k)), Phase.TO_HOLD
                    self.layer_counts[k] = self.layer_counts.get(k, 0) + 1
                    return Grant(uav, w.site, False, hold, self._alt(k))
        return None

    def _hover_where(self, uav: str, pos: Vec3) -> None:
        """``uav`` stopped at ``pos`` (it asks from there, hovering): only a small volume there is its now, if
        that fits (it should: it was inside its volumes), else it keeps what it held."""
        u = self._uavs.get(uav)
        vols = None if u is None else u.volumes
        if not vols or u is None:
            return
        if len(vols) == 1 and vols[0].kind == "hover":
            return
        here = stopped_at((pos[0], pos[1]), self._snap(pos[2]), vols)
        if self._free(uav, here):
            u.volumes = here
            u.origin = None
            self._version += 1

    def _arrive_at_hold(self, u: UavAirspace) -> None:
        """It hovers at its hold point: only the hover is its now."""
        assert u.hold is not None
        u.phase = Phase.AT_HOLD
        u.origin = None
        hxy = (u.hold.point_m[0], u.hold.point_m[1])
        alt = u.hold.layer_m
        u.volumes = [Volume(hxy, hxy, alt, alt, self.zone_slack_m, "hover")]
        self._version += 1


def _same(a: Vec3, b: Vec3) -> bool:
    """The same site (column): the same point horizontally."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) < 1e-3


__all__ = [
    "AT_HOLD_M",
    "DEFAULT_LAYER_SPACING_M",
    "HOVER_SLACK_M",
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
