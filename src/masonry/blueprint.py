"""Wall blueprint values (bricks, markers, fleet) and their loading and validation.

The values are frozen; positions are world ENU metres, angles radians. The YAML file format (documented in
docs/blueprint-format.md, JSON Schema from :mod:`masonry.schema`) uses the keys ``position``, ``size``,
``pickup`` and ``home``; the Python values carry the unit in the name (``position_m``, ...).

:func:`parse_blueprint` validates everything the planner relies on and raises :class:`BlueprintError`
naming the file, the brick id or field, and the problem, on the first error found.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from masonry.errors import BlueprintError
from masonry.geofence import Site
from masonry.placement_check import PLACEMENT_KEYS, PlacementCheck, parse_placement_check, placement_lines
from masonry.spares import Spare, format_spares, parse_spares

if TYPE_CHECKING:
    from masonry.adhesive import Adhesive
    from masonry.planner.contacts import Contacts

Role = Literal["brick", "adhesion"]
ROLES: tuple[str, ...] = ("brick", "adhesion")

DEFAULT_CLEARANCE_M = 1.5
DEFAULT_CRUISE_ALTITUDE_M = 1.2
DEFAULT_BRICK_SIZE_M = (0.30, 0.15, 0.10)

#: ArUco dictionaries a blueprint may name (the predefined dictionaries of OpenCV's aruco module).
ARUCO_DICTIONARIES: tuple[str, ...] = tuple(
    [f"DICT_{n}X{n}_{k}" for n in (4, 5, 6, 7) for k in (50, 100, 250, 1000)]
    + ["DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10"]
    + ["DICT_APRILTAG_36h11", "DICT_ARUCO_MIP_36h12"]
)
#: Number of markers in each dictionary (OpenCV's predefined sets): brick k needs ids 2k and 2k+1 in it.
ARUCO_DICTIONARY_SIZES: dict[str, int] = {
    **{f"DICT_{n}X{n}_{k}": k for n in (4, 5, 6, 7) for k in (50, 100, 250, 1000)},
    "DICT_ARUCO_ORIGINAL": 1024,
    "DICT_APRILTAG_16h5": 30,
    "DICT_APRILTAG_25h9": 35,
    "DICT_APRILTAG_36h10": 2320,
    "DICT_APRILTAG_36h11": 587,
    "DICT_ARUCO_MIP_36h12": 250,
}
#: Bricks must be taller than twice the 5 mm resting tolerance so "rests on" is unambiguous and G^d acyclic.
MIN_BRICK_HEIGHT_M = 0.01
#: The most bricks any ArUco dictionary can number (DICT_APRILTAG_36h10: 2320 markers, two per brick).
MAX_MARKED_BRICKS = 1160
#: Brick ids of a planner-only study (``validate_blueprint(..., check_marker_ids=False)``) stay below this.
MAX_BRICK_ID = 10**9 - 1

# Limits of a real site (docs/blueprint-format.md, "Limits"): values beyond them are typing mistakes or hostile
# input, and far beyond them they overflow the motion and camera arithmetic.
#: Every x and y (brick, pickup, home) lies within this distance of the site origin: a 2 km square site.
SITE_HALF_EXTENT_M = 1000.0
#: Every z lies below this (a 30-storey building); brick centres and the cruise altitude too.
SITE_MAX_HEIGHT_M = 100.0
#: The largest brick dimension (a concrete block is 0.4 m; a 5 m "brick" is a beam, not masonry).
MAX_BRICK_DIMENSION_M = 5.0
#: |yaw| of a brick at most two turns.
MAX_ABS_YAW_RAD = 2.0 * math.tau
#: The clearance r_c: above 10 m two UAVs on one wall could never work at once (the paper uses 1.5 m).
MAX_CLEARANCE_M = 10.0
#: A pickup's brick and a home stand on the ground or a platform no higher than this (a truck bed, a scaffold).
MAX_PICKUP_HEIGHT_M = 10.0
MAX_HOME_HEIGHT_M = 10.0
#: A brick that does not stand on the ground must have at least this fraction of its footprint on the bricks
#: under it: a running-bond end brick over a half-brick offset has 0.5; below a quarter the adhesive, not the
#: brick below, would have to hold it (and the centre of mass is then far out over the edge).
MIN_SUPPORT_FRACTION = 0.25
#: UAV names: part of every Zenoh key (masonry/<mission>/to/<name>), so letters, digits, `-`, `_`, `.` only
#: (no key-expression characters `*`, `$`, `/`, `#`, `?`), starting with a letter or digit, 1-64 characters.
UAV_NAME_PATTERN = r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}"
#: Mission control's own endpoint name (masonry.mission.messages.MISSION_CONTROL): no UAV may take it.
RESERVED_UAV_NAMES: tuple[str, ...] = ("mission-control",)
#: A value quoted in an error line is cut to this many characters.
QUOTE_MAX_CHARS = 80


@dataclass(frozen=True)
class MarkerSpec:
    """The two ArUco markers on each brick's top face (brick k carries ids 2k and 2k+1)."""

    dictionary: str = "DICT_4X4_50"
    size_m: float = 0.05
    spacing_m: float = 0.175


@dataclass(frozen=True)
class Brick:
    """One brick of the wall: its blueprint pose, size, and where it waits to be picked up."""

    id: int
    position_m: tuple[float, float, float]
    size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M
    yaw_rad: float = 0.0
    placed: bool = False
    pickup_m: tuple[float, float, float] | None = None
    #: the brick's marker number m (ArUco ids 2m, 2m+1); None: its id (docs/blueprint-format.md, "Markers")
    marker: int | None = None

    @property
    def bottom_z_m(self) -> float:
        return self.position_m[2] - self.size_m[2] / 2.0

    @property
    def top_z_m(self) -> float:
        return self.position_m[2] + self.size_m[2] / 2.0

    @property
    def top_center_m(self) -> tuple[float, float, float]:
        return (self.position_m[0], self.position_m[1], self.top_z_m)

    def footprint_m(self) -> tuple[tuple[float, float], ...]:
        """Corners of the brick's footprint (a rotated rectangle), counter-clockwise."""
        hx, hy = self.size_m[0] / 2.0, self.size_m[1] / 2.0
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        x0, y0 = self.position_m[0], self.position_m[1]
        return tuple(
            (x0 + c * dx - s * dy, y0 + s * dx + c * dy)
            for dx, dy in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
        )

    @property
    def marker_number(self) -> int:
        """The brick's marker number m: ``marker`` if the blueprint gives one, else its id."""
        return self.id if self.marker is None else self.marker

    def marker_ids(self) -> tuple[int, int]:
        """The ArUco ids on this brick: 2m (at +spacing/2 on the length axis) and 2m+1 (at -spacing/2)."""
        m = self.marker_number
        return (2 * m, 2 * m + 1)


@dataclass(frozen=True)
class UavSpec:
    """One UAV of the fleet."""

    name: str
    role: Role
    home_m: tuple[float, float, float]


@dataclass(frozen=True)
class Blueprint:
    """A validated wall blueprint."""

    bricks: tuple[Brick, ...]
    fleet: tuple[UavSpec, ...]
    name: str | None = None
    clearance_m: float = DEFAULT_CLEARANCE_M
    cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M
    brick_size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M
    markers: MarkerSpec = field(default_factory=MarkerSpec)
    source: str = "<blueprint>"
    #: the site's geofence (None: no fence; docs/blueprint-format.md, "Site")
    site: Site | None = None
    #: the adhesive's open and cure times (None: neither is modelled; docs/blueprint-format.md, "Adhesive")
    adhesive: Adhesive | None = None
    #: spare bricks (None: no ``spares`` key, no spare accounting; docs/blueprint-format.md, "Spares")
    spares: tuple[Spare, ...] | None = None
    #: the as-built check of each placed brick (docs/blueprint-format.md, "As-built check")
    placement: PlacementCheck = field(default_factory=PlacementCheck)

    def brick(self, brick_id: int) -> Brick:
        """The brick with id ``brick_id`` (KeyError if there is none)."""
        index = self.__dict__.get("_brick_index")
        if index is None:
            index = {b.id: b for b in self.bricks}
            # A cache, not state: written around the frozen __setattr__ on purpose.
            object.__setattr__(self, "_brick_index", index)
        return index[brick_id]  # type: ignore[no-any-return]

    def uavs(self, role: Role) -> tuple[UavSpec, ...]:
        return tuple(u for u in self.fleet if u.role == role)


# ---------------------------------------------------------------------------------------------- loading

TOP_KEYS = (
    "name",
    "clearance",
    "cruise_altitude",
    "brick",
    "bricks",
    "fleet",
    "site",
    "adhesive",
    "spares",
    *PLACEMENT_KEYS,
)
BRICK_DEFAULT_KEYS = ("size", "markers")
MARKER_KEYS = ("dictionary", "size", "spacing")
BRICK_KEYS = ("id", "position", "yaw", "placed", "size", "pickup", "marker")
UAV_KEYS = ("name", "role", "home")


def load_blueprint(path: str | Path, *, check_marker_ids: bool = True) -> Blueprint:
    """Read, parse and validate a YAML blueprint file (``check_marker_ids``: see :func:`validate_blueprint`).

    Raises:
        BlueprintError: the file is unreadable, not YAML, or not a valid blueprint (one line naming the
            file, the brick id or field, and the problem).
    """
    import yaml

    from masonry.blueprint_yaml import FileLimitError, YamlLimitError, read_text_limited, safe_load

    source = str(path)
    try:
        text = read_text_limited(path)
    except FileNotFoundError:
        raise BlueprintError(source, "", "no such file") from None
    except IsADirectoryError:
        raise BlueprintError(source, "", "is a directory, not a blueprint file") from None
    except FileLimitError as exc:
        raise BlueprintError(source, "", str(exc)) from None
    except UnicodeDecodeError as exc:
        raise BlueprintError(
            source,
            "",
            f"not UTF-8 text (byte {exc.object[exc.start]:#04x} at offset "
            f"{exc.start}): a blueprint is a YAML or JSON file",
        ) from None
    except OSError as exc:
        raise BlueprintError(source, "", f"cannot read: {exc.strerror or exc}") from None
    try:
        data = safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        label = "" if isinstance(exc, YamlLimitError) else "YAML syntax error: "
        raise BlueprintError(source, where, f"{label}{_cut(problem)}") from None
    return parse_blueprint(data, source, check_marker_ids=check_marker_ids)


def parse_blueprint(data: Any, source: str = "<blueprint>", *, check_marker_ids: bool = True) -> Blueprint:
    """Build and validate a :class:`Blueprint` from already-parsed YAML/JSON data.

    Raises:
        BlueprintError: on the first problem found, naming ``source``, the field or brick, and the problem.
    """
    if data is None:
        raise BlueprintError(source, "", "empty file: expected a mapping with `bricks` and `fleet`")
    if not isinstance(data, Mapping):
        raise BlueprintError(source, "", f"not a mapping: the top level is {_kind(data)}")
    _check_keys(data, TOP_KEYS, ("bricks", "fleet"), source, "")
    name = data.get("name")
    if name is not None and not isinstance(name, str):
        raise BlueprintError(source, "name", f"must be a string, got {_kind(name)}")
    clearance = _positive(data.get("clearance", DEFAULT_CLEARANCE_M), source, "clearance")
    cruise = _positive(data.get("cruise_altitude", DEFAULT_CRUISE_ALTITUDE_M), source, "cruise_altitude")

    default_size = DEFAULT_BRICK_SIZE_M
    markers = MarkerSpec()
    defaults = data.get("brick", {})
    if defaults is None:
        defaults = {}
    if not isinstance(defaults, Mapping):
        raise BlueprintError(source, "brick", f"must be a mapping, got {_kind(defaults)}")
    _check_keys(defaults, BRICK_DEFAULT_KEYS, (), source, "brick")
    if "size" in defaults:
        default_size = _size(defaults["size"], source, "brick.size")
    if "markers" in defaults:
        markers = _markers(defaults["markers"], source)

    raw_bricks = data["bricks"]
    if not isinstance(raw_bricks, list):
        raise BlueprintError(source, "bricks", f"must be a list of bricks, got {_kind(raw_bricks)}")
    if not raw_bricks:
        raise BlueprintError(source, "bricks", "is empty: a blueprint needs at least one brick")
    bricks: list[Brick] = []
    seen_ids: dict[int, int] = {}
    for index, raw in enumerate(raw_bricks):
        brick = _brick(raw, index, default_size, source)
        if brick.id in seen_ids:
            raise BlueprintError(
                source, f"brick {brick.id}", f"duplicate brick id (bricks[{seen_ids[brick.id]}] has it too)"
            )
        seen_ids[brick.id] = index
        bricks.append(brick)

    raw_fleet = data["fleet"]
    if not isinstance(raw_fleet, list):
        raise BlueprintError(source, "fleet", f"must be a list of UAVs, got {_kind(raw_fleet)}")
    fleet: list[UavSpec] = []
    seen_names: set[str] = set()
    for index, raw in enumerate(raw_fleet):
        uav = _uav(raw, index, source)
        if uav.name in seen_names:
            raise BlueprintError(source, f"fleet UAV {quote(uav.name)}", "duplicate UAV name")
        seen_names.add(uav.name)
        fleet.append(uav)

    from masonry.adhesive import parse_adhesive
    from masonry.site_checks import parse_site

    blueprint = Blueprint(
        bricks=tuple(bricks),
        fleet=tuple(fleet),
        name=name,
        clearance_m=clearance,
        cruise_altitude_m=cruise,
        brick_size_m=default_size,
        markers=markers,
        source=source,
        site=parse_site(data.get("site"), source),
        adhesive=parse_adhesive(data.get("adhesive"), source),
        spares=parse_spares(data.get("spares"), source, default_size),
        placement=parse_placement_check(data, source),
    )
    validate_blueprint(blueprint, check_marker_ids=check_marker_ids)
    return blueprint


def validate_blueprint(
    blueprint: Blueprint, contacts: Contacts | None = None, *, check_marker_ids: bool = True
) -> None:
    """Check a blueprint's geometry and fleet (what the value types alone cannot guarantee).

    ``contacts`` (from :func:`masonry.planner.contacts.find_contacts` on the same bricks) saves recomputing.
    ``check_marker_ids=False`` is for studies of the planner alone on walls larger than any ArUco dictionary
    can number (over ``MAX_MARKED_BRICKS`` bricks): brick ids are then only bounded by ``MAX_BRICK_ID``. Every
    command that flies or simulates keeps the check (docs/blueprint-format.md, "Limits").

    Raises:
        BlueprintError: a value beyond the site limits or a marker id beyond its dictionary, a UAV name that is
            not a Zenoh key chunk, interpenetrating bricks, a floating or barely supported brick, a placed brick
            on an unplaced one, an unplaced brick without pickup, a marker layout that does not fit, a fleet
            missing a role, a pickup or home inside the wall or shared, or a cruise altitude below the wall's top.
    """
    from masonry.blueprint_checks import validate

    validate(blueprint, contacts, check_marker_ids=check_marker_ids)


def _check_uav_name(name: Any, source: str, where: str) -> None:
    if not isinstance(name, str) or not re.fullmatch(UAV_NAME_PATTERN, name):
        raise BlueprintError(
            source,
            where,
            f"{quote(name)} is not a UAV name: 1-64 letters, digits, `-`, `_` or "
            "`.`, starting with a letter or digit (it is part of the mission's Zenoh keys)",
        )
    if name in RESERVED_UAV_NAMES:
        raise BlueprintError(source, where, f"{quote(name)} is mission control's own name")


RESTING_TOL_M = 0.005
PENETRATION_TOL_M = 0.005


def _brick(raw: Any, index: int, default_size: tuple[float, float, float], source: str) -> Brick:
    where = f"bricks[{index}]"
    if not isinstance(raw, Mapping):
        raise BlueprintError(source, where, f"must be a mapping, got {_kind(raw)}")
    if "id" in raw:
        bid = raw["id"]
        if isinstance(bid, bool) or not isinstance(bid, int) or bid < 0:
            raise BlueprintError(source, f"{where}: id", f"must be an integer >= 0, got {quote(bid)}")
        where = f"brick {bid}"
    _check_keys(raw, BRICK_KEYS, ("id", "position"), source, where)
    position = _vec3(raw["position"], source, f"{where}: position")
    size = _size(raw["size"], source, f"{where}: size") if "size" in raw else default_size
    yaw = _number(raw.get("yaw", 0.0), source, f"{where}: yaw")
    placed = raw.get("placed", False)
    if not isinstance(placed, bool):
        raise BlueprintError(source, f"{where}: placed", f"must be true or false, got {quote(placed)}")
    pickup = raw.get("pickup")
    pickup_m = None if pickup is None else _vec3(pickup, source, f"{where}: pickup")
    marker = raw.get("marker")
    if marker is not None and (isinstance(marker, bool) or not isinstance(marker, int) or marker < 0):
        raise BlueprintError(source, f"{where}: marker", f"must be an integer >= 0, got {quote(marker)}")
    return Brick(
        id=int(raw["id"]),
        position_m=position,
        size_m=size,
        yaw_rad=yaw,
        placed=placed,
        pickup_m=pickup_m,
        marker=marker,
    )


def _uav(raw: Any, index: int, source: str) -> UavSpec:
    where = f"fleet[{index}]"
    if not isinstance(raw, Mapping):
        raise BlueprintError(source, where, f"must be a mapping, got {_kind(raw)}")
    name = raw.get("name")
    if isinstance(name, str) and name.strip():
        where = f"fleet UAV {quote(name)}"
    _check_keys(raw, UAV_KEYS, ("name", "role", "home"), source, where)
    if not isinstance(name, str) or not name.strip():
        raise BlueprintError(source, f"{where}: name", f"must be a non-empty string, got {quote(name)}")
    _check_uav_name(name, source, f"{where}: name")
    role = raw["role"]
    if role not in ROLES:
        raise BlueprintError(
            source, f"{where}: role", f"unknown role {quote(role)} (expected one of: {', '.join(ROLES)})"
        )
    home = _vec3(raw["home"], source, f"{where}: home")
    return UavSpec(name=name, role=role, home_m=home)


def _markers(raw: Any, source: str) -> MarkerSpec:
    where = "brick.markers"
    if not isinstance(raw, Mapping):
        raise BlueprintError(source, where, f"must be a mapping, got {_kind(raw)}")
    _check_keys(raw, MARKER_KEYS, (), source, where)
    dictionary = raw.get("dictionary", MarkerSpec.dictionary)
    if dictionary not in ARUCO_DICTIONARIES:
        raise BlueprintError(
            source, f"{where}.dictionary", f"unknown ArUco dictionary {quote(dictionary)} (e.g. DICT_4X4_50)"
        )
    size = _positive(raw.get("size", MarkerSpec.size_m), source, f"{where}.size")
    spacing = _positive(raw.get("spacing", MarkerSpec.spacing_m), source, f"{where}.spacing")
    return MarkerSpec(dictionary=dictionary, size_m=size, spacing_m=spacing)


def _check_keys(
    raw: Mapping[Any, Any], allowed: tuple[str, ...], required: tuple[str, ...], source: str, where: str
) -> None:
    for key in raw:
        if key not in allowed:
            hint = _close_match(str(key)[:100], allowed)
            problem = f"unknown key {quote(key)}" + (f" (did you mean {hint!r}?)" if hint else "")
            problem += f"; allowed: {', '.join(allowed)}"
            raise BlueprintError(source, where, problem)
    for key in required:
        if key not in raw:
            raise BlueprintError(source, where, f"missing key {quote(key)}")


def _close_match(key: str, allowed: tuple[str, ...]) -> str | None:
    import difflib

    matches = difflib.get_close_matches(key, allowed, n=1)
    return matches[0] if matches else None


def _number(raw: Any, source: str, where: str) -> float:
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise BlueprintError(source, where, f"must be a number, got {_kind(raw)} {quote(raw)}")
    value = float(raw)
    if not math.isfinite(value):
        raise BlueprintError(source, where, f"must be a finite number, got {quote(raw)}")
    return value


def _positive(raw: Any, source: str, where: str) -> float:
    value = _number(raw, source, where)
    if value <= 0.0:
        raise BlueprintError(source, where, f"must be > 0, got {quote(raw)}")
    return value


def _vec3(raw: Any, source: str, where: str) -> tuple[float, float, float]:
    if not isinstance(raw, (list, tuple)) or len(raw) != 3:
        raise BlueprintError(
            source, where, f"must be a list of 3 numbers [x, y, z] in metres, got {quote(raw)}"
        )
    x, y, z = (_number(v, source, where) for v in raw)
    return (x, y, z)


def _size(raw: Any, source: str, where: str) -> tuple[float, float, float]:
    if not isinstance(raw, (list, tuple)) or len(raw) != 3:
        raise BlueprintError(
            source, where, f"must be a list of 3 numbers [length, width, height] in metres, got {quote(raw)}"
        )
    values = tuple(_number(v, source, where) for v in raw)
    if any(v <= 0.0 for v in values):
        raise BlueprintError(source, where, f"every dimension must be > 0, got {quote(list(raw))}")
    return (values[0], values[1], values[2])


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, Mapping):
        return "a mapping"
    return type(value).__name__


def _fmt(value: float) -> str:
    return f"{value:.6g}"


def _cut(text: str, limit: int = 2 * QUOTE_MAX_CHARS) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def quote(value: Any, limit: int = QUOTE_MAX_CHARS) -> str:
    """``repr(value)`` for an error line, at most ``limit`` characters whatever the value's size.

    The work is bounded too: a list of 200,000 numbers or an alias-built tree is never rendered whole.
    """
    import reprlib

    r = reprlib.Repr()
    r.maxlevel, r.maxlist, r.maxtuple, r.maxdict, r.maxset = 3, 6, 6, 4, 4
    r.maxstring, r.maxother, r.maxlong = limit, limit, 40
    text = r.repr(value)
    if isinstance(value, (list, tuple, dict)) and len(value) > 6:
        text += f" ({len(value)} items)"
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ---------------------------------------------------------------------------------------------- writing


def format_blueprint(blueprint: Blueprint, header: str = "") -> str:
    """The YAML text of a blueprint (one flow-style line per brick and UAV), readable by :func:`load_blueprint`.

    ``header`` lines are written first as ``#`` comments. Per-brick ``size`` is written only where it differs
    from the blueprint's default brick size.
    """
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    if blueprint.name is not None:
        lines.append(f"name: {_yaml_str(blueprint.name)}")
    lines.append(f"clearance: {_num(blueprint.clearance_m)}")
    lines.append(f"cruise_altitude: {_num(blueprint.cruise_altitude_m)}")
    m = blueprint.markers
    lines.append("brick:")
    lines.append(f"  size: {_vec(blueprint.brick_size_m)}")
    lines.append(
        f"  markers: {{dictionary: {m.dictionary}, size: {_num(m.size_m)}, spacing: {_num(m.spacing_m)}}}"
    )
    lines.append("bricks:")
    for b in blueprint.bricks:
        parts = [f"id: {b.id}", f"position: {_vec(b.position_m)}"]
        if b.yaw_rad != 0.0:
            parts.append(f"yaw: {_num(b.yaw_rad)}")
        if b.size_m != blueprint.brick_size_m:
            parts.append(f"size: {_vec(b.size_m)}")
        if b.placed:
            parts.append("placed: true")
        if b.pickup_m is not None:
            parts.append(f"pickup: {_vec(b.pickup_m)}")
        if b.marker is not None:
            parts.append(f"marker: {b.marker}")
        lines.append("  - {" + ", ".join(parts) + "}")
    lines.append("fleet:")
    for u in blueprint.fleet:
        lines.append(f"  - {{name: {_yaml_str(u.name)}, role: {u.role}, home: {_vec(u.home_m)}}}")
    if blueprint.site is not None:
        from masonry.site_checks import format_site

        lines.append(format_site(blueprint.site))
    if blueprint.adhesive is not None:
        from masonry.adhesive import format_adhesive

        lines.append(format_adhesive(blueprint.adhesive))
    if blueprint.spares is not None:
        lines.append(format_spares(blueprint.spares, blueprint.brick_size_m, _num))
    if (
        blueprint.placement != PlacementCheck()
    ):  # (the defaults are not written: old files read back the same)
        lines.extend(placement_lines(blueprint.placement, _num))
    return "\n".join(lines) + "\n"


def _num(value: float) -> str:
    rounded = round(float(value), 9) + 0.0  # nanometres are plenty; + 0.0 turns -0.0 into 0.0
    return repr(rounded)


def _vec(values: tuple[float, ...]) -> str:
    return "[" + ", ".join(_num(v) for v in values) + "]"


def _yaml_str(text: str) -> str:
    import json

    return json.dumps(text)
