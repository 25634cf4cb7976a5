"""The airspace's records: its configuration, what each UAV holds, and the shapes those volumes take.

The base of :class:`~masonry.mission.airspace.ColumnClearance` (whose docstring gives the rules and the
constructor's arguments): one :class:`~masonry.mission.airspace_state.UavAirspace` per UAV, the layers' altitudes,
the pad, zone and flight volumes at them, and the two tests every decision asks (:meth:`AirspaceRecords.free`,
:meth:`AirspaceRecords.fits`). The protocol that changes the records is ColumnClearance's and its modules'
(``airspace_requests``, ``airspace_ground``, ``airspace_progress``). Pure: no I/O, no clock.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from masonry.geofence import Site
from masonry.mission.airspace_state import Phase, UavAirspace
from masonry.mission.altitudes import DEFAULT_LAYER_SPACING_M
from masonry.mission.fence import volumes_in_fence
from masonry.mission.sites import SiteGate
from masonry.mission.volumes import (
    XY,
    Vec3,
    Volume,
    column,
    flight_volumes,
    same_site,
    volumes_clear,
    volumes_conflict,
)
from masonry.separation import SEPARATION_XY_M, pad_separation_m, zone_slack_m

__all__ = ["DEFAULT_LAYER_SPACING_M", "SNAP_M", "AirspaceRecords"]

#: A UAV reported within this of a layer's altitude is at the layer (hover noise). UAVs come to rest where they
#: stop before they ask (``masonry.fsm``), so a UAV reported farther from a layer is where it says: a UAV at rest
#: 0.11 m over layer 0 after stopping a climb, counted at the layer, was 0.11 m outside its climb.
SNAP_M = 0.05


class AirspaceRecords:
    """Every UAV's record in the airspace and the volumes it may hold (the arguments: :class:`ColumnClearance`)."""

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
        #: each UAV's role (mission control's fleet; empty: every pad is kept clear of hold points): a hold point
        #: may lie by the pad of a landed UAV of the holder's role (:func:`masonry.mission.airspace_requests.hold_flight`)
        self.roles: dict[str, str] = {}
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

    @property
    def version(self) -> int:
        """Changes whenever a reservation changes (a take-off refused before may fit after it changed)."""
        return self._version

    def touch(self) -> None:
        """Something outside the reservations changed (the :class:`SiteGate`'s answers): look at every waiting
        request again."""
        self._version += 1

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
