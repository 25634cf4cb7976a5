"""The airspace at run time as a space-time reservation table (``--airspace table``; docs/safety.md, "The table
at run time"). :class:`TableClearance` answers what :class:`~masonry.mission.airspace.ColumnClearance` answers
from one :class:`~masonry.reservation.Table`: each hop granted as timed legs ending in an open-ended stay
(:func:`~masonry.reservation.decide`), a UAV waiting where it stays, a late one extended (the leg it flies as its
``plan_progress`` says, :mod:`masonry.mission.plan_reading`), a silent one keeping its way home, UAVs waiting at
sites for each other broken up by parking spots (:mod:`masonry.mission.reserved_parts`), a UAV held back far from
its site waiting over it (:mod:`masonry.mission.reserved_approach`). A request is decided in
:mod:`masonry.mission.reserved_requests`. No hold patience. Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping

from masonry.errors import InvalidArgument
from masonry.geofence import Site
from masonry.mission import reserved_requests
from masonry.mission.airspace_state import Grant, Phase
from masonry.mission.envelope import TableWindows
from masonry.mission.plan_reading import matching, reported_leg
from masonry.mission.reserved_approach import approach
from masonry.mission.reserved_parts import (
    arrived,
    cut_behind,
    end_flight,
    extend_or_force,
    forced,
    guarded,
    hover_start,
    leg_now,
    legs_under_way,
    park_levels,
    park_plan,
    park_spots,
    parking_order,
    silent_way,
    to_park,
)
from masonry.mission.reserved_requests import TableUav
from masonry.mission.sites import SiteGate
from masonry.mission.volumes import Vec3, same_site
from masonry.mission.volumes import Volume as AirVolume
from masonry.ports import PlanProgress
from masonry.reservation import (
    LEG_PIECE_M,
    Airspace,
    Fence,
    Reservation,
    Separation,
    Table,
    Volume,
    column,
    pad,
    violations,
)
from masonry.separation import LAYER_SPACING_M, SEPARATION_XY_M, pad_separation_m, zone_slack_m
from masonry.timing import DEFAULT_TIMING, TaskTiming

#: A UAV reported this close to its home (horizontally) and this low is on its pad (as ColumnClearance).
ON_PAD_XY_M = 0.3
ON_PAD_Z_M = 0.3

#: Seconds added to every window of a plan: a UAV this much behind a leg is still inside its window. The state
#: machines come to rest between legs and settle before they ask, which the timed legs do not count.
TABLE_MARGIN_S = 3.0

#: Seconds the other UAVs' windows are made longer when a flight is planned: room for their extensions.
TABLE_GUARD_S = 3.0

#: The airspaces mission control can run: ColumnClearance (the default) or :class:`TableClearance`.
AIRSPACES = ("columns", "table")
DEFAULT_AIRSPACE = "columns"

_FLIGHT = ("climb", "transit", "descend", "work", "site", "home")


class TableClearance:
    """Mission control's airspace backed by a space-time reservation table (see the module docstring). Args: those of :class:`~masonry.mission.airspace.ColumnClearance` (``radius_m`` the blueprint's r_c, which
    widens work zones as it does there; ``base_m`` the transit layer base, None for no airspace rules), and
    ``timing`` (the UAVs' speeds the legs are timed with) and ``margin_s`` (added to every window);
    ``layer_climb_mps``: the climbs' and descents' peak speed (None: ``timing``'s, 0.4 m/s; the UAVs fly 0.9 m/s and
    run up to 7 s ahead of their windows, docs/performance/fleet.md, ``climb50``).
    """

    def __init__(
        self,
        radius_m: float,
        base_m: float | None = None,
        spacing_m: float = LAYER_SPACING_M,
        homes: Mapping[str, Vec3] | None = None,
        sep_xy_m: float = SEPARATION_XY_M,
        start_base_m: float | None = None,
        pad_separation_m: float = pad_separation_m(),
        gate: SiteGate | None = None,
        fence: Site | None = None,
        *,
        timing: TaskTiming = DEFAULT_TIMING,
        margin_s: float | None = None,
        guard_s: float | None = None,
        max_layers: int = 4,
        layer_climb_mps: float | None = None,
    ) -> None:
        if not (radius_m >= 0.0 and math.isfinite(radius_m)):
            raise InvalidArgument(f"column radius must be a finite number >= 0, got {radius_m!r}")
        self.base_m = None if base_m is None else float(base_m)
        self.layer_base_m = self.base_m
        if self.base_m is not None and start_base_m is not None:
            self.layer_base_m = min(self.base_m, float(start_base_m))
        self.spacing_m = float(spacing_m)
        self.sep_xy_m = float(sep_xy_m)
        self.zone_r_m = zone_slack_m(float(radius_m), self.sep_xy_m)
        self.gate, self.fence, self.timing = gate, fence, timing
        self.margin_s = float(TABLE_MARGIN_S if margin_s is None else margin_s)
        self.guard_s = float(TABLE_GUARD_S if guard_s is None else guard_s)
        self.max_layers = max_layers
        self.layer_climb_mps = None if layer_climb_mps is None else float(layer_climb_mps)
        self.homes: dict[str, Vec3] = {
            u: (float(h[0]), float(h[1]), float(h[2])) for u, h in (homes or {}).items()
        }
        self.table = Table(
            separation=Separation(self.sep_xy_m, self.spacing_m - 1e-9, float(pad_separation_m) - 1e-6)
        )
        self._uavs: dict[str, TableUav] = {}
        self.on_change: Callable[[Table, float], object] = lambda table, now_s: None  # (a log watches)
        self.seq, self._version, self.now_s, self.granted_count = 0, 0, 0.0, 0
        self.held_back = 0  # flights to a parking spot (the watchdog's signature reads it)
        self.refused = 0  # answers "wait where you are"
        self.extended = 0  # windows extended for a late UAV
        self.forced = 0  # extensions no move could make room for (the table then holds a clash: counted)
        self.plan_read = 0  # reports whose plan_progress spoke of the UAV's current plan
        self.fence_refusals: dict[str, str] = {}
        #: is this a UAV's flight to its task's site (then, held back far from it, it waits at the approach spot
        #: over it)? None: no approach spots (:mod:`masonry.mission.reserved_approach`)
        self.work_site: Callable[[str, Vec3], bool] | None = None
        self.approached_count, self.lifted_count, self.lifting = 0, 0, True  # (lift spots: reserved_lift.py)
        self._levels = park_levels(self.homes, self.sep_xy_m)
        self._windows = TableWindows()  # (reserved_at's)
        self.airspace = self._make_airspace()
        if self.base_m is not None:
            for uav in self.homes:
                self.set_stay(uav, self._pad_volume(uav), Phase.LANDED)

    def use_timing(self, timing: TaskTiming) -> None:
        """Time the legs with ``timing`` (the UAVs' speeds) from now on."""
        self.timing, self.airspace = timing, self._make_airspace(timing)

    # -- what mission control reads -----------------------------------------------------------------------
    @property
    def version(self) -> int:
        """Changes whenever a reservation changes or ends (a take-off refused before may fit after it)."""
        return self._version

    @property
    def release_radius_m(self) -> float:  # (the UAVs say they left a site this far away: windows end by time)
        return self.sep_xy_m

    @property
    def waiting(self) -> tuple[str, ...]:
        """UAVs mission control must look at every tick (:meth:`grant`): a request waiting or a flight under way
        (its windows are extended if it runs late), in request order."""
        asking = sorted((u.request.seq, n) for n, u in self._uavs.items() if u.request is not None)
        flying = sorted(n for n, u in self._uavs.items() if u.plan is not None and u.request is None)
        return (*(n for _s, n in asking), *flying)

    def phase(self, uav: str) -> Phase:
        u = self._uavs.get(uav)
        return Phase.PARKED if u is None else u.phase

    def asked_for(self, uav: str) -> Vec3 | None:
        u = self._uavs.get(uav)
        return None if u is None or u.request is None else u.request.site

    def blockers(self, uav: str) -> list[tuple[str, str]]:
        """``(other UAV, purpose of its reservation)`` in the way of what ``uav`` waits for (``site-rule``: the
        site gate holds it back; ``approach``: it flies to its approach spot)."""
        u = self._uavs.get(uav)
        return [] if u is None or u.request is None else list(u.blocked_by)

    def volumes(self, uav: str) -> tuple[AirVolume, ...]:
        """``uav``'s reservations from now on, as airspace volumes (for the events and the live view)."""
        return tuple(
            AirVolume(r.volume.a, r.volume.b, r.volume.z0_m, r.volume.z1_m, r.volume.radius_m, r.purpose)
            for r in self.table.of(uav)
            if r.t1_s > self.now_s and r.purpose != "site"
        )

    def reserved_at(self, uav: str, t_s: float) -> tuple[AirVolume, ...]:
        """``uav``'s volumes whose window holds ``t_s`` (:class:`~masonry.mission.envelope.ReservedSpace`)."""
        return self._windows.at(self.table, uav, t_s)

    def conflicts(self) -> list[tuple[str, str]]:
        """Pairs of UAVs whose reservations clash (empty unless a late UAV's extension was forced)."""
        return sorted({tuple(sorted((p.uav, q.uav))) for p, q in violations(self.table)})  # type: ignore[misc]

    # -- the protocol -----------------------------------------------------------------------------------
    def raise_base(self, altitude_m: float) -> None:
        """Transit layers granted from now on clear ``altitude_m`` (never above ``base_m``)."""
        if self.base_m is None or self.layer_base_m is None:
            return
        z = min(self.base_m, float(altitude_m))
        if z > self.layer_base_m:
            self.layer_base_m = z
            self.airspace = self._make_airspace()
            self._version += 1

    def touch(self) -> None:
        """The site gate's answers may have changed: look at every waiting request again."""
        self._version += 1

    def request(
        self,
        uav: str,
        site_m: Vec3,
        now_s: float,
        position_m: Vec3 | None = None,
        top_m: float | None = None,
        to_m: Vec3 | None = None,
    ) -> Grant:
        """``uav`` (at ``position_m``) sets off for ``site_m``, to work there up to ``top_m`` (along to ``to_m``):
        its hop is granted if it fits now, else it waits where it is (:func:`masonry.mission.reserved_requests.request`)."""
        return reserved_requests.request(self, uav, site_m, now_s, position_m, top_m, to_m)

    def grant(self, now_s: float) -> list[Grant]:
        """Every tick: windows that ended are dropped, late UAVs' windows extended, and waiting requests answered
        in request order where the table changed (only grants are returned: a wait is said when asked)."""
        self.tick(now_s)
        for uav, u in self._uavs.items():
            if u.plan is not None:  # (flying, or stopped in it: it turned back and waits for its new flight)
                self._keep_up(uav, u, now_s)
        out: list[Grant] = []
        for uav in self.waiting:
            u = self._uavs[uav]
            if u.request is None or (u.seen_version == self._version and now_s < u.retry_s):
                continue
            if u.phase is Phase.TO_HOLD:  # on its way to its parking spot: asked again once it is there
                continue
            g = reserved_requests.evaluate(self, uav, u, now_s)
            if g.granted:
                out.append(g)
        out += reserved_requests.lift_in_way(self, self._uavs, now_s)  # (waiting UAVs in a waiting one's way)
        park = self._park(now_s)
        return out if park is None else [*out, park]

    def _park(self, now_s: float) -> Grant | None:
        """Send one waiting UAV in a cycle of waits at sites to its parking spot, if its flight there fits now."""
        asking = {
            n: u
            for n, u in self._uavs.items()
            if u.request is not None
            and (u.phase is Phase.ASKING or (u.phase is Phase.AT_HOLD and u.hovering))
        }
        # (whose way a UAV is in: any waiting UAV's, one hovering at its parking spot too)
        waits = {
            n: u.blocked_by
            for n, u in self._uavs.items()
            if u.request is not None and u.phase in (Phase.ASKING, Phase.AT_HOLD)
        }
        endless = [n for n, u in asking.items() if math.isinf(u.retry_s)]
        order = {n: u.request.seq for n, u in asking.items() if u.request is not None}
        for uav in to_park(waits, endless, order):
            u = asking[uav]
            assert u.request is not None
            if not u.approach:  # to the approach spot by its site, if it may go there: no detour home
                hop = reserved_requests.hop_request(self, uav, u, u.request)
                sent = approach(self, uav, u, u.request, (*hop.start.xy, hop.start.z_m), now_s)
                if sent is not None:
                    return sent
            home = self.homes.get(uav)
            start = u.spot if u.hovering else (u.request.position or u.position)
            if home is None or start is None:
                continue
            # a UAV hovering where it turned back leaves from its hover (on its layer, a few centimetres over where
            # it asked: from 8 cm under it, 1.02 m over a neighbour's stay, neither UAV of a cycle of two could be
            # parked, bench_layouts --compact --faults --airspace table seed 70)
            start = hover_start(self.table.stay_of(uav), start)
            top, n, plan = self._home_top_m(), self.max_layers, None
            parked = {o: p.spot for o, p in self._uavs.items() if p.spot is not None and not p.hovering}
            spots = park_spots(home, top, n, self.spacing_m, self._levels, uav)
            # (never in the way down of a UAV parked before it: reserved_parts.parking_order)
            for spot in parking_order(uav, spots, self.airspace.layers_m[-1], parked, self.table.separation):
                plan = park_plan(self.guarded_for(uav), uav, start, spot, now_s, self.airspace)
                if plan is not None:
                    break
            if plan is None:
                continue
            stay = self.table.stay_of(uav)
            left = self.table if stay is None else forced(self.table, [stay], [stay.until(now_s)])
            self.table = forced(left, [], plan.reservations)
            u.phase, u.plan, u.spot, u.site, u.approach = Phase.TO_HOLD, plan, spot, u.request.site, False
            u.flown_on, u.down_to, u.lifted = False, None, False
            self.held_back += 1
            self.bump()
            return Grant(uav, u.request.site, False, spot, spot[2])
        return None

    def at_spot(self, uav: str, u: TableUav) -> None:
        """A UAV flying to its parking spot is there (it said so): it hovers there, its flight's windows end; over
        its plan's stay (turned back: :func:`reserved_requests.fly_on`) it flies on down into the stay first."""
        if u.phase is Phase.TO_HOLD and arrived(u.position, u.spot):
            if u.down_to is not None:
                u.spot, u.down_to = u.down_to, None
                return
            self._replace(uav, end_flight(self.table.of(uav), self.now_s, _FLIGHT))
            u.phase, u.plan, u.seen_version = Phase.AT_HOLD, None, -1

    def end_transit(self, uav: str) -> None:
        """``uav`` is down at its site: its flight's windows end now, its stay there starts now."""
        u = self._uavs.get(uav)
        if u is None or u.plan is None:
            return
        kept = end_flight(self.table.of(uav), self.now_s, _FLIGHT)
        self._replace(uav, kept)
        u.plan, u.phase = None, Phase.PARKED

    def can_take_off(self, uav: str) -> bool:
        """``uav`` may take off now: not landed, or its pad's column is free and no hold keeps it down (the table's)."""
        u = self._uavs.get(uav)
        if self.base_m is None or u is None or u.phase is not Phase.LANDED:
            return True
        up = Reservation(uav, self._pad_column(uav), self.now_s, math.inf, "stay")
        return not self.table.clashes(up) and not any(h.covers(uav, self.now_s) for h in self.table.holds)

    def take_off(self, uav: str) -> bool:
        """``uav``, landed, takes off if it may (:meth:`can_take_off`; False: it stays on its pad): it holds the
        column over its pad from now on. A UAV not landed holds what it needs (True)."""
        if not self.can_take_off(uav):
            return False
        u = self._uavs.get(uav)
        if self.base_m is not None and u is not None and u.phase is Phase.LANDED:
            self.set_stay(uav, self._pad_column(uav), Phase.PARKED)
        return True

    def landed(self, uav: str, position_m: Vec3) -> bool:
        """``uav`` is on the ground at ``position_m``: on its pad it holds only the pad from now on (True)."""
        u = self._uavs.get(uav)
        if self.base_m is None or u is None or u.phase is Phase.LANDED or u.request is not None:
            return False
        if not self._on_pad(uav, position_m, ON_PAD_Z_M):
            return False
        self.set_stay(uav, self._pad_volume(uav), Phase.LANDED)
        return True

    def rejoined(
        self, uav: str, position_m: Vec3 | None, way_home: tuple[float | None, Vec3 | None] | None = None
    ) -> bool:
        """``uav``, out of the mission, is heard again at ``position_m``: on its pad it holds the pad; in the air
        the column where it hovers (and, with ``way_home``, its way home); down elsewhere it is not back (False)."""
        home = self.homes.get(uav)
        if self.base_m is None or home is None or position_m is None:
            return True
        x, y, z = (float(v) for v in position_m)
        if z - home[2] <= ON_PAD_Z_M:
            if not self._on_pad(uav, position_m, math.inf):
                return False
            self.set_stay(uav, self._pad_volume(uav), Phase.LANDED)
            return True
        self.set_stay(uav, column((x, y), 0.0, max(z, self._home_top_m())), Phase.PARKED)
        if way_home is not None:
            self.silent(uav, (x, y, z), way_home[0], way_home[1])
        return True

    def silent(self, uav: str, position_m: Vec3, layer_m: float | None, via_m: Vec3 | None = None) -> float:
        """``uav`` fell silent at ``position_m``: what it holds stays its (open-ended), and its way home at its
        fallback ``layer_m`` (through ``via_m``'s column: a brick put back first) is reserved, until mission control
        releases it. Returns the way's length in metres."""
        home = self.homes.get(uav)
        if home is None or self.base_m is None:
            return 0.0
        home_m = (home[0], home[1], self._home_top_m())
        self.table, length_m = silent_way(
            self.table, uav, position_m, layer_m, via_m, home_m, self.now_s, self.timing, self.fence
        )
        self.bump()
        return length_m

    def release(self, uav: str, site_m: Vec3 | None = None) -> None:
        """``uav`` gave up asking for ``site_m`` (or left it: its windows end by themselves); None: it is out of the
        mission (on the ground or fallen): everything it holds is freed."""
        if site_m is None:
            self._uavs.pop(uav, None)
            self._replace(uav, [])
            return
        u = self._uavs.get(uav)
        if u is not None and u.request is not None and same_site(u.request.site, site_m):
            u.request, u.phase = None, (Phase.PARKED if u.plan is None else u.phase)
            self.bump()

    def progress(self, uav: str, position_m: Vec3, plan_progress: PlanProgress | None = None) -> None:
        """``uav`` reports where it is (and its ``plan_progress``, :mod:`~masonry.mission.plan_reading`): the legs
        behind it end now, the leg it flies holds only what lies ahead of it (:func:`~masonry.mission.reserved_parts.ahead_of`)."""
        u = self._uavs.get(uav)
        if u is None:
            return
        u.position = (float(position_m[0]), float(position_m[1]), float(position_m[2]))
        u.reported, self.plan_read = plan_progress, self.plan_read + (matching(u, plan_progress) is not None)
        self.at_spot(uav, u)
        if u.phase not in (Phase.FLYING, Phase.TO_HOLD) or u.plan is None:
            return  # (a flight to a parking or approach spot too: its climb over the site it left ends)
        at = reported_leg(u, legs_under_way(self.table.of(uav), self.now_s), self.now_s)
        cut = cut_behind(self.table.of(uav), u.position, self.now_s, at)
        if cut is not None:  # (the part of its leg it has flown out of is free too)
            self._replace(uav, cut)

    # -- internals ---------------------------------------------------------------------------------------
    def _make_airspace(self, timing: TaskTiming | None = None) -> Airspace:
        base = self.layer_base_m if self.layer_base_m is not None else 0.0
        layers = tuple(base + k * self.spacing_m for k in range(self.max_layers))
        t = timing or self.timing  # (legs at any layer, as the columns grant them: Airspace.any_layer)
        return Airspace(
            layers,
            t.cruise_speed_mps,
            t.vertical_speed_mps if self.layer_climb_mps is None else self.layer_climb_mps,
            self.margin_s,
            0.0,
            any_layer=True,
            first_arrival=True,
            piece_m=LEG_PIECE_M,
            fence=None if self.fence is None else Fence(self.fence),  # (no leg granted outside it)
        )

    def tick(self, now_s: float) -> None:
        """Time moves on: windows that ended bind nobody (dropped; a change: waits are looked at again)."""
        self.now_s = max(self.now_s, float(now_s))
        if any(r.t1_s <= self.now_s for r in self.table.reservations):
            self.table = self.table.prune(self.now_s)
            self.bump()

    def _keep_up(self, uav: str, u: TableUav, now_s: float) -> None:
        """A UAV still in a leg whose window ends within half the margin: its windows are extended by the margin
        (:func:`extend`; the plans of others in the way move, or, when none can, the extension is forced); the leg
        it is in is :func:`leg_now`'s (at the top of its climb, on its transit: not late)."""
        legs = legs_under_way(self.table.of(uav), now_s)
        at = reported_leg(u, legs, now_s)  # (the leg its report says, else the one its position is in)
        at = leg_now(legs, u.position, now_s) if at is None else at
        current = legs[at] if at is not None else (legs[0] if legs else self.table.stay_of(uav))
        if (
            current is None
            or current.t0_s > now_s + self.margin_s / 2
            or current.t1_s - now_s > self.margin_s / 2
        ):
            return  # (a stay it is in has no end: nothing to extend)
        self.extended += 1
        self.table, was_forced = extend_or_force(self.table, uav, now_s, self.margin_s)
        self.forced += was_forced
        self.bump()

    def guarded_for(self, uav: str) -> Table:
        """The table ``uav``'s flight is planned in (:func:`~masonry.mission.reserved_parts.guarded`)."""
        stopped = {n for n, o in self._uavs.items() if o.plan is not None and o.request is not None}
        return guarded(self.table, uav, self.now_s, self.guard_s, stopped)

    def set_stay(self, uav: str, volume: Volume, phase: Phase) -> None:
        """``uav`` holds only ``volume``, open-ended, from now on (it is there: nothing is checked)."""
        u = self.record(uav)
        u.plan, u.phase = None, phase
        kept = [
            r.until(self.now_s)
            for r in self.table.of(uav)
            if r.t0_s < self.now_s < r.t1_s and r.purpose == "lost"
        ]
        self._replace(uav, [*kept, Reservation(uav, volume, self.now_s, math.inf, "stay")])

    def _replace(self, uav: str, reservations: Iterable[Reservation]) -> None:
        """``uav``'s reservations are ``reservations`` from now on (what it physically holds: not checked)."""
        self.table = forced(self.table, self.table.of(uav), list(reservations))
        self.bump()

    def bump(self) -> None:  # (every change: a wait is looked at again, on_change sees the table)
        self._version += 1
        self.on_change(self.table, self.now_s)

    def record(self, uav: str) -> TableUav:
        u = self._uavs.get(uav)
        if u is None:
            u = self._uavs[uav] = TableUav()
        return u

    def _home_top_m(self) -> float:
        return self.base_m if self.base_m is not None else 0.0

    def _pad_volume(self, uav: str) -> Volume:
        return pad(self.homes[uav][:2])

    def _pad_column(self, uav: str) -> Volume:
        return column(self.homes[uav][:2], 0.0, self._home_top_m())

    def _on_pad(self, uav: str, position_m: Vec3, max_z_m: float) -> bool:
        home = self.homes.get(uav)
        if home is None:
            return False
        x, y, z = (float(v) for v in position_m)
        return math.hypot(x - home[0], y - home[1]) <= ON_PAD_XY_M and z - home[2] <= max_z_m


__all__ = ["AIRSPACES", "DEFAULT_AIRSPACE", "TABLE_MARGIN_S", "TableClearance"]
