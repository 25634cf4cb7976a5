"""Airspace separation between UAVs: reserved volumes, handed out by mission control at run time.

The paper's conflict graph G^c keeps the task *locations* (drop-off points, adhesion segments) r_c apart; it
says nothing about the flights between them nor about the shared pickup pallet. :class:`ColumnClearance`
closes that gap (docs/safety.md):

- Every UAV holds a set of :class:`Volume` s: the **zone** where it works (the column over its site, from the
  ground to the highest altitude it reaches there), or the whole **flight** it was granted (a vertical climb where
  it is, a lateral leg at its layer, the column over the site it flies to).
- A flight is granted only if every one of its volumes keeps the separation from every volume of every other
  UAV (:func:`volumes_conflict`): two UAVs that stay in their volumes are never closer than the separation.
- Lateral legs fly on **layers** ``base + k * spacing``; ``base`` is the highest altitude at which any task of
  the wall is worked (:func:`work_altitude_m`), and a flight takes the lowest layer on which all of it fits.
- A UAV that cannot have its flight because the site is busy gets a **hold flight** to a point near it, out of
  everyone's way, and the rest of the flight when it fits; first come, first served.
- Volumes shrink as the UAV reports where it is: the part of its leg behind it is freed, and the flight becomes
  the zone at its site once it is down.

The state machines fly exactly these shapes: climb (or descend) vertically where they are, fly straight at the
layer, come down vertically over the site (``masonry.fsm``). Mission control runs the rules, so they work the
same in-process and across Zenoh (messages ``clearance-request`` / ``clearance``).

Everything here is pure (no I/O, no clock).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from masonry.blueprint import Blueprint, UavSpec
from masonry.planner.tasks import BrickTask, Task
from masonry.timing import DEFAULT_TIMING, TaskTiming

Vec3 = tuple[float, float, float]
XY = tuple[float, float]

#: Vertical distance between two transit layers: the 1 m separation target plus tracking error and gusts.
DEFAULT_LAYER_SPACING_M = 1.1


def work_altitude_m(blueprint: Blueprint, *, timing: TaskTiming | None = None) -> float:
    """The highest altitude at which a UAV works any task of ``blueprint`` (cruise altitude at least).

    The same formulas as the state machines' site altitudes (``masonry.fsm``, flying ``timing``, default:
    ``UavConfig``'s): a brick UAV keeps the carried brick ``clearance_m`` above the drop-off
    (:meth:`TaskTiming.carry_altitude_m`), an adhesion UAV its nozzle ``clearance_m`` above the spraying height
    (:meth:`TaskTiming.spray_altitude_m`).
    """
    t = DEFAULT_TIMING if timing is None else timing
    z = float(blueprint.cruise_altitude_m)
    for b in blueprint.bricks:
        size_z = float(b.size_m[2])
        z = max(z, _work_altitude_over_m(float(b.position_m[2]) + size_z / 2.0, size_z, t))
    return z


def task_work_altitude_m(task: Task, cruise_altitude_m: float, *, timing: TaskTiming | None = None) -> float:
    """The highest altitude at which a UAV works ``task``, as :func:`work_altitude_m` counts it for its brick
    (a brick task: carrying its brick over its drop-off, and spraying on its top later) or its surface (an
    adhesion task); at least ``cruise_altitude_m``.

    Once the task is assigned its brick may be on the wall: a transit layer at or above this clears it.
    """
    t = DEFAULT_TIMING if timing is None else timing
    if isinstance(task, BrickTask):
        size_z = float(task.size_m[2])
        top = float(task.position_m[2]) + size_z / 2.0
        return max(float(cruise_altitude_m), _work_altitude_over_m(top, size_z, t))
    surface = max(float(task.start_m[2]), float(task.end_m[2]))
    return max(float(cruise_altitude_m), _work_altitude_over_m(surface, 0.0, t))


def _work_altitude_over_m(top_m: float, size_z_m: float, timing: TaskTiming) -> float:
    """Where a UAV works over a brick top at ``top_m``: carrying a brick ``size_z_m`` high down onto it (0: no
    brick), or spraying it."""
    z = timing.spray_altitude_m(top_m)
    if size_z_m > 0.0:
        z = max(z, timing.carry_altitude_m(top_m, size_z_m))
    return z


#: How far a UAV may be off its reserved path (tracking error, a report a little late): what lies further behind
#: it on its leg is freed (:meth:`ColumnClearance.progress`).
TRACK_M = 0.3

#: A UAV that stopped mid-flight to ask for another site (it turned back) holds this much around where it is.
HOVER_SLACK_M = 0.3

#: How far a UAV flying a leg may coast on after it is told to stop (1.9 m/s peak, 2.5 m/s^2 braking, margin).
STOP_M = 1.0

#: A UAV reported within this of a layer's altitude is at the layer (hover noise). UAVs come to rest where they
#: stop before they ask (``masonry.fsm``), so a UAV reported farther from a layer is where it says: a UAV at rest
#: 0.11 m over layer 0 after stopping a climb, counted at the layer, was 0.11 m outside its climb.
SNAP_M = 0.05

#: A UAV within this of its hold point (horizontally) hovers there: the state machines count a leg as done
#: within 0.08 m (``UavConfig.arrive_tolerance_m``), and only then read the rest of their flight.
AT_HOLD_M = 0.1

#: Layer 0 starts this far above the highest work altitude (the spacing of the layers above it has its own
#: margin over the separation target).
LAYER_MARGIN_M = 0.0


def layer_base_m(blueprint: Blueprint, *, timing: TaskTiming | None = None) -> float:
    """Altitude of transit layer 0 for ``blueprint``: :func:`work_altitude_m` plus :data:`LAYER_MARGIN_M`."""
    return work_altitude_m(blueprint, timing=timing) + LAYER_MARGIN_M


def transit_layers_m(
    blueprint: Blueprint,
    fleet: Sequence[UavSpec] | None = None,
    spacing_m: float = DEFAULT_LAYER_SPACING_M,
    *,
    timing: TaskTiming | None = None,
) -> dict[str, float]:
    """Altitude of each UAV's lateral legs: ``work_altitude_m + (k + 1) * spacing_m``, k its index in ``fleet``.

    ``fleet`` defaults to the blueprint's. A UAV flying its own mission process (``masonry fly --mission``) gets
    the same layer as in ``masonry sim``, because both number the blueprint's fleet the same way. ``timing``:
    the UAVs' (default: ``UavConfig``'s), for the work altitude.
    """
    if not (spacing_m >= 0.0 and math.isfinite(spacing_m)):
        raise ValueError(f"layer spacing must be a finite number >= 0, got {spacing_m!r}")
    members = tuple(blueprint.fleet if fleet is None else fleet)
    base = layer_base_m(blueprint, timing=timing)
    return {u.name: base + (k + 1) * spacing_m for k, u in enumerate(members)}


@dataclass(frozen=True)
class Volume:
    """A piece of airspace reserved for one UAV: every point within ``slack_m`` (horizontally) of the 2-D
    segment ``a``-``b``, between altitudes ``z0_m`` and ``z1_m``.

    A vertical move is a degenerate segment (``a == b``) over an altitude range, a lateral leg a segment at one
    altitude, a site's work zone a vertical column from the ground with the work's horizontal ``slack_m``.
    """

    a: XY
    b: XY
    z0_m: float
    z1_m: float
    slack_m: float = 0.0
    kind: str = "leg"  # "climb", "leg", "zone", "hover": what it is, for diagnostics and early release


def volumes_conflict(p: Volume, q: Volume, sep_xy_m: float, sep_z_m: float) -> bool:
    """Could a UAV in ``p`` come within the separation of one in ``q``?

    No if their altitude ranges are ``sep_z_m`` apart, or their horizontal footprints ``sep_xy_m`` (plus both
    slacks) apart. Two UAVs in volumes that do not conflict are at least min(sep_xy_m, sep_z_m) apart.
    """
    if p.z0_m - q.z1_m >= sep_z_m or q.z0_m - p.z1_m >= sep_z_m:
        return False
    need = sep_xy_m + p.slack_m + q.slack_m
    # cheap reject on the bounding boxes before the exact segment distance
    if (min(p.a[0], p.b[0]) - max(q.a[0], q.b[0]) >= need or min(q.a[0], q.b[0]) - max(p.a[0], p.b[0]) >= need
            or min(p.a[1], p.b[1]) - max(q.a[1], q.b[1]) >= need
            or min(q.a[1], q.b[1]) - max(p.a[1], p.b[1]) >= need):
        return False
    return _segment_segment_m(p.a, p.b, q.a, q.b) < need


@dataclass(frozen=True)
class Grant:
    """Mission control's answer to a UAV setting off for ``site_m``.

    ``layer_m``: the altitude of its lateral leg (None: no layers, fly as you like, or no flight yet).
    ``granted`` True: fly there (climb where you are to ``layer_m``, fly over the site, come down). False with a
    ``hold_m``: fly (at ``layer_m``) to ``hold_m`` and wait there, the rest comes later. False without: hover
    where you are and ask again.
    """

    uav: str
    site_m: Vec3
    granted: bool = True
    hold_m: Vec3 | None = None
    layer_m: float | None = None


@dataclass
class _Pending:
    site: Vec3
    top_m: float
    position: Vec3 | None
    since_s: float
    to: XY | None = None  # the work at the site spans from it to here (an adhesion segment)
    hold: Vec3 | None = None  # the hold point of its hold flight (granted), if any
    layer: int | None = None  # the layer of that hold flight
    layer_alt: float | None = None  # its altitude (the layer base may have risen since)
    at_hold: bool = False
    seen_version: int = -1  # airspace version at its last evaluation (nothing changed since: same answer)
    answer: Grant | None = None


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
    - **Waiting**: when no layer fits because the site's column is not free (another UAV works or is about to
      come down there), the UAV gets a *hold flight* to a hold point near the site, at least ``radius_m``
      (horizontally) from every zone and every site another UAV waits for, where it hovers at its layer until the
      rest of the flight (the leg on to the site and the descent) fits. A UAV whose hold flight does not fit
      either hovers where it is and asks again.
    - **Order**: requests are served first come, first served: a flight may not come down within ``radius_m`` of
      the site of a UAV that asked earlier and still waits.
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
        homes: each UAV's home: it starts in the zone over it (it takes off and lands there).
        sep_xy_m: horizontal separation between volumes (the 1 m target plus the horizontal tracking error).
        start_base_m: altitude of layer 0 at the start (e.g. the cruise altitude), raised by :meth:`raise_base`
            (None: ``base_m`` throughout).
    """

    def __init__(self, radius_m: float, base_m: float | None = None,
                 spacing_m: float = DEFAULT_LAYER_SPACING_M, homes: Mapping[str, Vec3] | None = None,
                 sep_xy_m: float = 1.2, start_base_m: float | None = None) -> None:
        if not (radius_m >= 0.0 and math.isfinite(radius_m)):
            raise ValueError(f"column radius must be a finite number >= 0, got {radius_m!r}")
        if not (spacing_m > 0.0 and math.isfinite(spacing_m)):
            raise ValueError(f"layer spacing must be a finite number > 0, got {spacing_m!r}")
        if not (sep_xy_m > 0.0 and math.isfinite(sep_xy_m)):
            raise ValueError(f"separation must be a finite number > 0, got {sep_xy_m!r}")
        self.radius_m = float(radius_m)
        self.base_m = None if base_m is None else float(base_m)
        #: altitude of layer 0 now: from ``start_base_m`` up to ``base_m`` as the wall rises (:meth:`raise_base`)
        self.layer_base_m = self.base_m
        if self.base_m is not None and start_base_m is not None:
            self.layer_base_m = min(self.base_m, float(start_base_m))
        self.spacing_m = float(spacing_m)
        self.sep_xy_m = float(sep_xy_m)
        #: horizontal slack of a zone: two zones are ``radius_m`` apart
        self.zone_slack_m = max(0.0, (self.radius_m - self.sep_xy_m) / 2.0)
        self.max_layers = 12
        self._volumes: dict[str, list[Volume]] = {}
        self._zone: dict[str, Vec3] = {}  # uav -> site of the zone it works in
        # uav -> (site, layer index, layer altitude) of its granted flight
        self._flight: dict[str, tuple[Vec3, int, float]] = {}
        self._origin: dict[str, Vec3] = {}  # uav -> site it set off from (its climb is freed once away)
        self._waiting: dict[str, _Pending] = {}  # insertion order = first come, first served
        self._homes: dict[str, Vec3] = {u: (float(h[0]), float(h[1]), float(h[2])) for u, h in (homes or {}).items()}
        # uav -> (top, end of the work's span) of the zone at the site of its granted flight
        self._tops: dict[str, tuple[float, XY | None]] = {}
        self._version = 0
        self.granted_count = 0
        self.held_back = 0  # hold flights given (a UAV sent to wait near its site)
        self.refused = 0  # requests answered "hover where you are"
        self.wait_s = 0.0  # summed time between request and grant
        self.max_wait_s = 0.0
        self.layer_counts: dict[int, int] = {}  # granted flights per layer index
        if self.base_m is not None:
            for uav, home in self._homes.items():
                self._set_zone(uav, home, self.base_m)

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
        for uav in self._volumes:
            f = self._flight.get(uav)
            if f is not None:
                out[uav] = (f[0],)
            elif uav in self._zone and self._zone[uav] != self._homes.get(uav):
                out[uav] = (self._zone[uav],)
        return out

    @property
    def waiting(self) -> tuple[str, ...]:
        """UAVs waiting for their flight, in request order."""
        return tuple(self._waiting)

    @property
    def layers(self) -> dict[str, int]:
        """UAV -> layer index of its flight in progress (granted, or to its hold point)."""
        out = {u: f[1] for u, f in self._flight.items()}
        out.update({u: w.layer for u, w in self._waiting.items() if w.layer is not None})
        return out

    def volumes(self, uav: str) -> tuple[Volume, ...]:
        """The volumes ``uav`` holds now."""
        return tuple(self._volumes.get(uav, ()))

    def layer_m(self, uav: str) -> float | None:
        """Altitude of ``uav``'s flight in progress (None: none, or no layers)."""
        if self.base_m is None:
            return None
        f = self._flight.get(uav)
        if f is not None:
            return f[2]
        w = self._waiting.get(uav)
        return None if w is None else w.layer_alt

    def conflicts(self) -> list[tuple[str, str]]:
        """Pairs of UAVs whose volumes conflict now: always empty (the invariant the tests check)."""
        names = list(self._volumes)
        out = []
        for i, u in enumerate(names):
            for w in names[i + 1:]:
                if any(volumes_conflict(p, q, self.sep_xy_m, self.spacing_m - 1e-9)
                       for p in self._volumes[u] for q in self._volumes[w]):
                    out.append((u, w))
        return out

    # -- the protocol -----------------------------------------------------------------------------------------
    def request(self, uav: str, site_m: Vec3, now_s: float, position_m: Vec3 | None = None,
                top_m: float | None = None, to_m: Vec3 | None = None) -> Grant:
        """``uav`` (now at ``position_m``) sets off for ``site_m``, where it will work up to ``top_m`` (and along
        to ``to_m``: an adhesion UAV sprays from its site to there).

        A repeated request (same site) gets the same answer unless something changed, and keeps its place in the
        queue; one for another site replaces the UAV's pending one (its volumes stay until the new flight is
        granted: it is still where they are).
        """
        site = (float(site_m[0]), float(site_m[1]), float(site_m[2]))
        top = max(site[2], float(top_m) if top_m is not None else site[2])
        if self.base_m is None:
            self.granted_count += 1
            return Grant(uav, site)
        f = self._flight.get(uav)
        if f is not None:
            if _same(f[0], site):
                return Grant(uav, site, layer_m=f[2])
            # turned back for another site: it keeps the volumes of that flight until it has a new one
            del self._flight[uav]
            self._tops.pop(uav, None)
        pos = None if position_m is None else (float(position_m[0]), float(position_m[1]), float(position_m[2]))
        w = self._waiting.get(uav)
        if w is not None and _same(w.site, site):
            if pos is not None and w.hold is None and pos != w.position:
                w.position = pos
                w.seen_version = -1  # where it asks from changed: look again
            return self._evaluate(uav, w, now_s)
        if w is not None:
            del self._waiting[uav]
        if pos is not None and uav not in self._zone:
            self._hover_where(uav, pos)  # it turned back mid-flight: it stays where it is until answered
        w = _Pending(site, top, pos, now_s)
        if to_m is not None and math.hypot(float(to_m[0]) - site[0], float(to_m[1]) - site[1]) > 1e-6:
            w.to = (float(to_m[0]), float(to_m[1]))
        self._waiting[uav] = w
        self._version += 1  # the queue changed: answers of those behind it may change
        return self._evaluate(uav, w, now_s)

    def grant(self, now_s: float) -> list[Grant]:
        """Answer waiting UAVs, in request order, whose answer changed (a flight granted, or a hold flight)."""
        out: list[Grant] = []
        for uav, w in list(self._waiting.items()):
            if w.seen_version == self._version:
                continue
            before = w.answer
            g = self._evaluate(uav, w, now_s)
            if g.granted or (g.hold_m is not None and (before is None or before.hold_m is None)):
                out.append(g)
        return out

    def end_transit(self, uav: str) -> None:
        """``uav``'s flight came down at its site: it holds the zone there now."""
        f = self._flight.pop(uav, None)
        if f is None:
            return
        self._origin.pop(uav, None)
        site = f[0]
        top, to = self._tops.pop(uav, (site[2], None))
        self._set_zone(uav, site, top, to)

    def release(self, uav: str, site_m: Vec3 | None = None) -> None:
        """``uav`` is ``release_radius_m`` away from where it was at ``site_m`` (its climb there is over), or gave
        up asking for it; None: it is out of the mission (on the ground or fallen): everything is freed."""
        if site_m is None:
            for table in (self._volumes, self._zone, self._flight, self._origin, self._waiting, self._tops):
                table.pop(uav, None)  # type: ignore[attr-defined]
            self._version += 1
            return
        w = self._waiting.get(uav)
        if w is not None and _same(w.site, site_m) and w.hold is None:
            del self._waiting[uav]  # given up before anything was granted
            self._version += 1
            return
        origin = self._origin.get(uav)
        if origin is not None and _same(origin, site_m):
            del self._origin[uav]
            vols = self._volumes.get(uav, [])
            kept = [v for v in vols if v.kind != "climb"]
            if len(kept) != len(vols):
                self._volumes[uav] = kept
                self._version += 1

    def progress(self, uav: str, position_m: Vec3) -> None:
        """``uav`` reports where it is: the part of its flight behind it is freed.

        Only a position on the flight's lateral leg (at its layer, within ``TRACK_M`` of the leg) or in the
        descent over its site counts; anything else (a report sent before the flight was granted, say) is ignored.
        A UAV flies its legs forward from rest to rest, so what lies more than ``TRACK_M`` behind it is left.
        """
        vols = self._volumes.get(uav)
        if not vols or self.base_m is None:
            return
        x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
        w = self._waiting.get(uav)
        if w is not None and w.hold is not None and not w.at_hold and w.layer_alt is not None \
                and math.hypot(x - w.hold[0], y - w.hold[1]) < AT_HOLD_M and abs(z - w.layer_alt) < 0.2:
            self._arrive_at_hold(uav, w)  # it hovers at its hold point
            return
        kept: list[Volume] | None = None
        last_leg: Volume | None = None
        for i, v in enumerate(vols):
            if v.kind != "leg":
                continue
            last_leg = v
            (ax, ay), (bx, by) = v.a, v.b
            dx, dy = bx - ax, by - ay
            length = math.hypot(dx, dy)
            if length < 1e-9 or abs(z - v.z0_m) >= 0.2:
                continue
            along = ((x - ax) * dx + (y - ay) * dy) / length
            across = abs((x - ax) * dy - (y - ay) * dx) / length
            if across > TRACK_M or along > length + TRACK_M:
                continue
            cut = along - TRACK_M
            if cut <= 0.0:
                return  # at the start of this leg: it may still be climbing (or stopped climbing) to it
            # on this leg: everything before it (its climb, earlier legs, a hover) is behind it
            rest = list(vols[i + 1:])
            if cut < length:
                f = max(0.0, cut) / length
                rest.insert(0, Volume((ax + f * dx, ay + f * dy), v.b, v.z0_m, v.z1_m, 0.0, "leg"))
            kept = rest
            break
        if kept is None:
            # coming down over its site at the end of its last leg (not a hold flight: that ends in a hover)
            zone = vols[-1]
            if last_leg is None or zone.kind != "zone" or z >= last_leg.z0_m - 0.2 or \
                    math.hypot(x - zone.a[0], y - zone.a[1]) >= TRACK_M or \
                    math.hypot(last_leg.b[0] - zone.a[0], last_leg.b[1] - zone.a[1]) > 1e-6:
                return
            kept = [zone]
        if len(kept) != len(vols) or any(k is not v for k, v in zip(kept, vols)):
            self._volumes[uav] = kept
            self._version += 1

    def blocking(self, uav: str, site_m: Vec3) -> list[str]:
        """The UAVs whose volumes keep ``uav`` from coming down at ``site_m`` now."""
        col = self._column(site_m, self.base_m or site_m[2])
        return [o for o, vols in self._volumes.items()
                if o != uav and any(self._conflict(col, v) for v in vols)]

    def hold_point(self, uav: str, site_m: Vec3, position_m: Vec3 | None = None) -> Vec3:
        """The point nearest to ``site_m`` at least ``radius_m`` from every other UAV's zone, flight site, hold
        point and the sites other UAVs wait for (the hover altitude is the layer; see :meth:`request`)."""
        return next(iter(self._hold_candidates(uav, site_m)))

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
        xy = (site[0], site[1])
        return Volume(xy, xy if to is None else to, 0.0, top, self.zone_slack_m, "zone")

    def _set_zone(self, uav: str, site: Vec3, top: float, to: XY | None = None) -> None:
        if uav in self._homes and _same(self._homes[uav], site) and self.base_m is not None:
            top = max(top, self.base_m)  # it takes off here up to its transit altitude
        self._zone[uav] = site
        self._volumes[uav] = [self._column(site, top, to)]
        self._version += 1

    def _free(self, uav: str, vols: list[Volume]) -> bool:
        """No volume of ``vols`` conflicts with another UAV's (:func:`volumes_conflict`, written out: this is
        mission control's inner loop)."""
        sep_xy, sep_z = self.sep_xy_m, self.spacing_m - 1e-9
        others = [q for other, theirs in self._volumes.items() if other != uav for q in theirs]
        for v in vols:
            vz0, vz1, vs = v.z0_m, v.z1_m, v.slack_m
            (ax, ay), (bx, by) = v.a, v.b
            vx0, vx1 = (ax, bx) if ax <= bx else (bx, ax)
            vy0, vy1 = (ay, by) if ay <= by else (by, ay)
            for q in others:
                if vz0 - q.z1_m >= sep_z or q.z0_m - vz1 >= sep_z:
                    continue
                need = sep_xy + vs + q.slack_m
                (cx, cy), (dx, dy) = q.a, q.b
                if (cx if cx <= dx else dx) - vx1 >= need or vx0 - (cx if cx >= dx else dx) >= need \
                        or (cy if cy <= dy else dy) - vy1 >= need or vy0 - (cy if cy >= dy else dy) >= need:
                    continue
                if _segment_segment_m(v.a, v.b, q.a, q.b) < need:
                    return False
        return True

    def _queued_before(self, uav: str) -> list[_Pending]:
        out = []
        for other, w in self._waiting.items():
            if other == uav:
                break
            out.append(w)
        return out

    def _flight_volumes(self, start: Vec3, target: Vec3 | None, top: float, k: int, hold: XY | None,
                        to: XY | None = None) -> list[Volume]:
        """Climb at ``start`` to layer ``k``, leg to the target (or the hold point), its column (or hover)."""
        alt = self._alt(k)
        sxy = (start[0], start[1])
        z0 = self._snap(start[2])
        vols = [Volume(sxy, sxy, min(z0, alt), max(z0, alt), 0.0, "climb")]
        end = hold if hold is not None else (target[0], target[1]) if target is not None else sxy
        if math.hypot(end[0] - sxy[0], end[1] - sxy[1]) > 1e-6:
            vols.append(Volume(sxy, end, alt, alt, 0.0, "leg"))
        if hold is not None:
            vols.append(Volume(end, end, alt, alt, self.zone_slack_m, "hover"))  # it may overshoot a little
        elif target is not None:
            vols.append(self._column(target, max(top, alt), to))
        return vols

    def _evaluate(self, uav: str, w: _Pending, now_s: float) -> Grant:
        """Grant ``uav``'s flight if it fits, else a hold flight, else "hover where you are"."""
        if w.seen_version == self._version and w.answer is not None:
            return w.answer
        w.seen_version = self._version
        earlier = self._queued_before(uav)
        blocked_site = any(math.hypot(e.site[0] - w.site[0], e.site[1] - w.site[1]) < self.radius_m
                           for e in earlier)
        if not blocked_site:
            if w.hold is not None and w.at_hold:
                # hovering at its hold point (it said so): from there, to the lowest layer that fits now, over to
                # the site and down. Not before: a UAV flies its hold flight to the end before it reads another
                # answer, and one that never saw its hold answer (a later one came first) would fly straight.
                assert w.layer_alt is not None
                hold = (w.hold[0], w.hold[1], w.layer_alt)
                for k in range(self.max_layers):
                    extra = self._flight_volumes(hold, w.site, w.top_m, k, None, w.to)
                    if self._free(uav, extra):
                        self._volumes[uav] = self._volumes.get(uav, []) + extra
                        self._version += 1
                        return self._granted(uav, w, k, now_s)
            elif w.hold is None:
                start = w.position if w.position is not None else w.site
                for k in range(self.max_layers):
                    vols = self._flight_volumes(start, w.site, w.top_m, k, None, w.to)
                    if self._free(uav, vols):
                        self._take(uav, vols, start)
                        return self._granted(uav, w, k, now_s)
        if w.hold is None:
            g = self._hold_flight(uav, w)
            if g is not None:
                w.answer = g
                self.held_back += 1
                return g
            self.refused += 1
            w.answer = Grant(uav, w.site, False)
            return w.answer
        assert w.layer_alt is not None
        w.answer = Grant(uav, w.site, False, w.hold, w.layer_alt)
        return w.answer

    def _take(self, uav: str, vols: list[Volume], start: Vec3) -> None:
        zone = self._zone.pop(uav, None)
        self._origin.pop(uav, None)  # a climb from mid-air (a UAV turned back) is kept until it is down
        if zone is not None:
            self._origin[uav] = zone
        self._volumes[uav] = vols
        self._version += 1

    def _granted(self, uav: str, w: _Pending, k: int, now_s: float) -> Grant:
        del self._waiting[uav]
        self._flight[uav] = (w.site, k, self._alt(k))
        self._tops[uav] = (w.top_m, w.to)
        waited = max(0.0, now_s - w.since_s)
        self.wait_s += waited
        self.max_wait_s = max(self.max_wait_s, waited)
        self.granted_count += 1
        self.layer_counts[k] = self.layer_counts.get(k, 0) + 1
        self._version += 1
        return Grant(uav, w.site, layer_m=self._alt(k))

    def _hold_candidates(self, uav: str, site: Vec3) -> list[Vec3]:
        keep_out: list[XY] = []
        for other, zone in self._zone.items():
            if other != uav:
                keep_out.extend(v.b for v in self._volumes.get(other, ()) if v.kind == "zone")
                keep_out.append((zone[0], zone[1]))
        for other, (fsite, _k, _alt) in self._flight.items():
            if other != uav:
                keep_out.append((fsite[0], fsite[1]))
        for other, ow in self._waiting.items():
            if other != uav:
                keep_out.append((ow.site[0], ow.site[1]))
                if ow.hold is not None:
                    keep_out.append((ow.hold[0], ow.hold[1]))
        # and wherever another UAV climbs, hovers or works: a UAV waiting there must be able to leave vertically
        # without passing the hold point (else the two could wait for each other)
        spans = [(v.a, v.b) for other, vols in self._volumes.items() if other != uav
                 for v in vols if v.kind != "leg"]
        r = 1.1 * self.radius_m
        r2 = r * r

        def free(p: XY) -> bool:
            return all((p[0] - k[0]) ** 2 + (p[1] - k[1]) ** 2 >= r2 for k in keep_out) and \
                all(_point_segment_m(p, a, b) >= r for a, b in spans)

        step = max(self.radius_m, 0.25)
        out: list[tuple[float, Vec3]] = []
        for ring in range(1, 9):
            for a in range(24):
                ang = 2.0 * math.pi * a / 24.0
                c = (site[0] + ring * step * math.cos(ang), site[1] + ring * step * math.sin(ang))
                if free(c):
                    out.append((ring * step, (c[0], c[1], site[2])))
            if len(out) >= 6:
                break
        return [p for _d, p in sorted(out, key=lambda x: x[0])] or [(site[0] + 8 * step, site[1], site[2])]

    def _hold_flight(self, uav: str, w: _Pending) -> Grant | None:
        """A flight to a hold point near the site, at the lowest layer that fits (None: none fits now)."""
        start = w.position if w.position is not None else w.site
        candidates = self._hold_candidates(uav, w.site)[:6]
        for k in range(self.max_layers):
            for hold in candidates:
                vols = self._flight_volumes(start, None, w.top_m, k, (hold[0], hold[1]))
                if self._free(uav, vols):
                    self._take(uav, vols, start)
                    w.hold = hold
                    w.layer = k
                    w.layer_alt = self._alt(k)
                    w.at_hold = False
                    self.layer_counts[k] = self.layer_counts.get(k, 0) + 1
                    return Grant(uav, w.site, False, hold, self._alt(k))
        return None

    def _hover_where(self, uav: str, pos: Vec3) -> None:
        """``uav`` stopped at ``pos`` (it asks from there, hovering): only a small volume there is its now, if
        that fits (it should: it was inside its volumes), else it keeps what it held."""
        vols = self._volumes.get(uav)
        if not vols:
            return
        z = self._snap(pos[2])
        xy = (pos[0], pos[1])
        here = [Volume(xy, xy, z - HOVER_SLACK_M, z + HOVER_SLACK_M, HOVER_SLACK_M, "hover")]
        if len(vols) == 1 and vols[0].kind == "hover":
            return
        for v in vols:  # stopping on a leg, it may coast on along it: keep STOP_M of the leg ahead
            length = math.hypot(v.b[0] - v.a[0], v.b[1] - v.a[1])
            if v.kind != "leg" or length < 1e-9 or abs(z - v.z0_m) >= 0.2 \
                    or _point_segment_m(xy, v.a, v.b) > TRACK_M:
                continue
            ux, uy = (v.b[0] - v.a[0]) / length, (v.b[1] - v.a[1]) / length
            along = (xy[0] - v.a[0]) * ux + (xy[1] - v.a[1]) * uy
            end = min(length, along + STOP_M)
            if end > along:
                here.append(Volume(xy, (v.a[0] + end * ux, v.a[1] + end * uy), v.z0_m, v.z1_m, 0.0, "leg"))
            break
        if self._free(uav, here):
            self._volumes[uav] = here
            self._origin.pop(uav, None)
            self._version += 1

    def _arrive_at_hold(self, uav: str, w: _Pending) -> None:
        """It hovers at its hold point: only the hover is its now."""
        assert w.hold is not None and w.layer_alt is not None
        w.at_hold = True
        self._origin.pop(uav, None)
        hxy = (w.hold[0], w.hold[1])
        alt = w.layer_alt
        self._volumes[uav] = [Volume(hxy, hxy, alt, alt, self.zone_slack_m, "hover")]
        self._version += 1


def _same(a: Vec3, b: Vec3) -> bool:
    """The same site (column): the same point horizontally."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) < 1e-3


def _point_segment_m(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    """Horizontal distance from ``p`` to the segment ``a``-``b``."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    n2 = dx * dx + dy * dy
    t = 0.0 if n2 == 0.0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / n2))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


def _segment_segment_m(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float],
                       d: tuple[float, float]) -> float:
    """Horizontal distance between segments ``a``-``b`` and ``c``-``d``."""
    def orient(p: tuple[float, float], q: tuple[float, float], r: tuple[float, float]) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if o1 * o2 < 0.0 and o3 * o4 < 0.0:
        return 0.0  # they cross
    return min(_point_segment_m(c, a, b), _point_segment_m(d, a, b), _point_segment_m(a, c, d),
               _point_segment_m(b, c, d))


def min_pairwise_separation_m(points: Iterable[Vec3]) -> float:
    """Smallest distance between two of ``points`` (inf for fewer than two): a helper for tests and reports."""
    pts = list(points)
    best = math.inf
    for i in range(len(pts) - 1):
        for j in range(i + 1, len(pts)):
            best = min(best, math.dist(pts[i], pts[j]))
    return best


__all__ = [
    "AT_HOLD_M",
    "DEFAULT_LAYER_SPACING_M",
    "HOVER_SLACK_M",
    "LAYER_MARGIN_M",
    "SNAP_M",
    "STOP_M",
    "TRACK_M",
    "ColumnClearance",
    "Grant",
    "Volume",
    "layer_base_m",
    "min_pairwise_separation_m",
    "task_work_altitude_m",
    "transit_layers_m",
    "volumes_conflict",
    "work_altitude_m",
]
