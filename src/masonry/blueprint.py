"""Wall blueprint values (bricks, markers, fleet) and their loading and validation.

The values are frozen; positions are world ENU metres, angles radians. The YAML file format (documented in
docs/blueprint-format.md, JSON Schema from :mod:`masonry.schema`) uses the keys ``position``, ``size``,
``pickup`` and ``home``; the Python values carry the unit in the name (``position_m``, ...).

:func:`parse_blueprint` validates everything the planner relies on and raises :class:`BlueprintError`
naming the file, the brick id or field, and the problem, on the first error found.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from masonry.errors import BlueprintError

if TYPE_CHECKING:
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
#: Bricks must be taller than twice the 5 mm resting tolerance so "rests on" is unambiguous and G^d acyclic.
MIN_BRICK_HEIGHT_M = 0.01


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

    def marker_ids(self) -> tuple[int, int]:
        """The ArUco ids on this brick: 2k (at +spacing/2 on the length axis) and 2k+1 (at -spacing/2)."""
        return (2 * self.id, 2 * self.id + 1)


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

TOP_KEYS = ("name", "clearance", "cruise_altitude", "brick", "bricks", "fleet")
BRICK_DEFAULT_KEYS = ("size", "markers")
MARKER_KEYS = ("dictionary", "size", "spacing")
BRICK_KEYS = ("id", "position", "yaw", "placed", "size", "pickup")
UAV_KEYS = ("name", "role", "home")


def load_blueprint(path: str | Path) -> Blueprint:
    """Read, parse and validate a YAML blueprint file.

    Raises:
        BlueprintError: the file is unreadable, not YAML, or not a valid blueprint (one line naming the
            file, the brick id or field, and the problem).
    """
    import yaml

    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise BlueprintError(source, "", "no such file") from None
    except IsADirectoryError:
        raise BlueprintError(source, "", "is a directory, not a blueprint file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise BlueprintError(source, "", f"cannot read: {exc}") from None
    from masonry.blueprint_yaml import safe_load

    try:
        data = safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise BlueprintError(source, where, f"YAML syntax error: {problem}") from None
    return parse_blueprint(data, source)


def parse_blueprint(data: Any, source: str = "<blueprint>") -> Blueprint:
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
            raise BlueprintError(source, f"fleet UAV {uav.name!r}", "duplicate UAV name")
        seen_names.add(uav.name)
        fleet.append(uav)

    blueprint = Blueprint(
        bricks=tuple(bricks),
        fleet=tuple(fleet),
        name=name,
        clearance_m=clearance,
        cruise_altitude_m=cruise,
        brick_size_m=default_size,
        markers=markers,
        source=source,
    )
    validate_blueprint(blueprint)
    return blueprint


def validate_blueprint(blueprint: Blueprint, contacts: Contacts | None = None) -> None:
    """Check a blueprint's geometry and fleet (what the value types alone cannot guarantee).

    ``contacts`` (from :func:`masonry.planner.contacts.find_contacts` on the same bricks) saves recomputing.

    Raises:
        BlueprintError: interpenetrating bricks, a floating brick, a placed brick on an unplaced one, an
            unplaced brick without pickup, a marker layout that does not fit, or a fleet missing a role.
    """
    from masonry.planner.contacts import BrickArrays, find_contacts

    source = blueprint.source
    bricks = blueprint.bricks
    markers = blueprint.markers
    for b in bricks:
        _check_brick_markers(b, markers, source)
        if not b.placed and b.pickup_m is None:
            raise BlueprintError(source, f"brick {b.id}", "`pickup` is required for a brick that is not placed")
    if contacts is None:
        positions = [b.position_m for b in bricks]
        contacts = find_contacts(BrickArrays.of(positions, [b.size_m for b in bricks], [b.yaw_rad for b in bricks]))
    if len(contacts.penetrating):
        i, j = (int(k) for k in contacts.penetrating[0])
        raise BlueprintError(
            source,
            f"brick {bricks[i].id}",
            f"its volume interpenetrates brick {bricks[j].id} (more than "
            f"{_fmt(PENETRATION_TOL_M * 1000)} mm overlap)",
        )
    supported = {int(u) for u in contacts.upper}
    for index, b in enumerate(bricks):
        bottom = b.bottom_z_m
        if abs(bottom) <= RESTING_TOL_M or index in supported:
            continue
        if bottom < -RESTING_TOL_M:
            problem = f"its bottom is below the ground (z = {_fmt(bottom)} m)"
        else:
            problem = (
                f"neither on the ground nor resting on a brick below it (bottom at z = {_fmt(bottom)} m; "
                f"no brick top within {_fmt(RESTING_TOL_M * 1000)} mm under its footprint)"
            )
        raise BlueprintError(source, f"brick {b.id}", problem)
    has_adhesion = False
    for u, v in zip(contacts.upper.tolist(), contacts.lower.tolist()):
        upper, lower = bricks[u], bricks[v]
        if upper.placed and not lower.placed:
            raise BlueprintError(
                source, f"brick {upper.id}", f"is placed but rests on brick {lower.id}, which is not placed"
            )
        if not upper.placed:
            has_adhesion = True
    roles = {u.role for u in blueprint.fleet}
    if "brick" not in roles:
        raise BlueprintError(source, "fleet", "has no UAV with role `brick` to place the bricks")
    if has_adhesion and "adhesion" not in roles:
        raise BlueprintError(
            source, "fleet", "has no UAV with role `adhesion`, but the plan has adhesion tasks"
        )


#: Same values as masonry.planner.contacts (kept here so the messages need no planner import).
RESTING_TOL_M = 0.005
PENETRATION_TOL_M = 0.005


def _check_brick_markers(b: Brick, markers: MarkerSpec, source: str) -> None:
    length, width, height = b.size_m
    if height <= 2 * RESTING_TOL_M:
        raise BlueprintError(
            source, f"brick {b.id}: size", f"height {_fmt(height)} m must exceed {_fmt(MIN_BRICK_HEIGHT_M)} m"
        )
    if markers.spacing_m + markers.size_m > length + 1e-9 or markers.size_m > width + 1e-9:
        raise BlueprintError(
            source,
            f"brick {b.id}: size",
            f"the two {_fmt(markers.size_m)} m markers {_fmt(markers.spacing_m)} m apart do not fit on its "
            f"{_fmt(length)} x {_fmt(width)} m top face",
        )


def _brick(raw: Any, index: int, default_size: tuple[float, float, float], source: str) -> Brick:
    where = f"bricks[{index}]"
    if not isinstance(raw, Mapping):
        raise BlueprintError(source, where, f"must be a mapping, got {_kind(raw)}")
    if "id" in raw:
        bid = raw["id"]
        if isinstance(bid, bool) or not isinstance(bid, int) or bid < 0:
            raise BlueprintError(source, f"{where}: id", f"must be an integer >= 0, got {bid!r}")
        where = f"brick {bid}"
    _check_keys(raw, BRICK_KEYS, ("id", "position"), source, where)
    position = _vec3(raw["position"], source, f"{where}: position")
    size = _size(raw["size"], source, f"{where}: size") if "size" in raw else default_size
    yaw = _number(raw.get("yaw", 0.0), source, f"{where}: yaw")
    placed = raw.get("placed", False)
    if not isinstance(placed, bool):
        raise BlueprintError(source, f"{where}: placed", f"must be true or false, got {placed!r}")
    pickup = raw.get("pickup")
    pickup_m = None if pickup is None else _vec3(pickup, source, f"{where}: pickup")
    return Brick(id=int(raw["id"]), position_m=position, size_m=size, yaw_rad=yaw, placed=placed, pickup_m=pickup_m)


def _uav(raw: Any, index: int, source: str) -> UavSpec:
    where = f"fleet[{index}]"
    if not isinstance(raw, Mapping):
        raise BlueprintError(source, where, f"must be a mapping, got {_kind(raw)}")
    name = raw.get("name")
    if isinstance(name, str) and name.strip():
        where = f"fleet UAV {name!r}"
    _check_keys(raw, UAV_KEYS, ("name", "role", "home"), source, where)
    if not isinstance(name, str) or not name.strip():
        raise BlueprintError(source, f"{where}: name", f"must be a non-empty string, got {name!r}")
    role = raw["role"]
    if role not in ROLES:
        raise BlueprintError(source, f"{where}: role", f"unknown role {role!r} (expected one of: {', '.join(ROLES)})")
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
            source, f"{where}.dictionary", f"unknown ArUco dictionary {dictionary!r} (e.g. DICT_4X4_50)"
        )
    size = _positive(raw.get("size", MarkerSpec.size_m), source, f"{where}.size")
    spacing = _positive(raw.get("spacing", MarkerSpec.spacing_m), source, f"{where}.spacing")
    return MarkerSpec(dictionary=dictionary, size_m=size, spacing_m=spacing)


def _check_keys(raw: Mapping[Any, Any], allowed: tuple[str, ...], required: tuple[str, ...], source: str, where: str) -> None:
    for key in raw:
        if key not in allowed:
            hint = _close_match(str(key), allowed)
            problem = f"unknown key {key!r}" + (f" (did you mean {hint!r}?)" if hint else "")
            problem += f"; allowed: {', '.join(allowed)}"
            raise BlueprintError(source, where, problem)
    for key in required:
        if key not in raw:
            raise BlueprintError(source, where, f"missing key {key!r}")


def _close_match(key: str, allowed: tuple[str, ...]) -> str | None:
    import difflib

    matches = difflib.get_close_matches(key, allowed, n=1)
    return matches[0] if matches else None


def _number(raw: Any, source: str, where: str) -> float:
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise BlueprintError(source, where, f"must be a number, got {_kind(raw)} {raw!r}")
    value = float(raw)
    if not math.isfinite(value):
        raise BlueprintError(source, where, f"must be a finite number, got {raw!r}")
    return value


def _positive(raw: Any, source: str, where: str) -> float:
    value = _number(raw, source, where)
    if value <= 0.0:
        raise BlueprintError(source, where, f"must be > 0, got {raw!r}")
    return value


def _vec3(raw: Any, source: str, where: str) -> tuple[float, float, float]:
    if not isinstance(raw, (list, tuple)) or len(raw) != 3:
        raise BlueprintError(source, where, f"must be a list of 3 numbers [x, y, z] in metres, got {raw!r}")
    x, y, z = (_number(v, source, where) for v in raw)
    return (x, y, z)


def _size(raw: Any, source: str, where: str) -> tuple[float, float, float]:
    if not isinstance(raw, (list, tuple)) or len(raw) != 3:
        raise BlueprintError(
            source, where, f"must be a list of 3 numbers [length, width, height] in metres, got {raw!r}"
        )
    values = tuple(_number(v, source, where) for v in raw)
    if any(v <= 0.0 for v in values):
        raise BlueprintError(source, where, f"every dimension must be > 0, got {list(raw)!r}")
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
    lines.append(f"  markers: {{dictionary: {m.dictionary}, size: {_num(m.size_m)}, spacing: {_num(m.spacing_m)}}}")
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
        lines.append("  - {" + ", ".join(parts) + "}")
    lines.append("fleet:")
    for u in blueprint.fleet:
        lines.append(f"  - {{name: {_yaml_str(u.name)}, role: {u.role}, home: {_vec(u.home_m)}}}")
    return "\n".join(lines) + "\n"


def _num(value: float) -> str:
    rounded = round(float(value), 9) + 0.0  # nanometres are plenty; + 0.0 turns -0.0 into 0.0
    return repr(rounded)


def _vec(values: tuple[float, ...]) -> str:
    return "[" + ", ".join(_num(v) for v in values) + "]"


def _yaml_str(text: str) -> str:
    import json

    return json.dumps(text)
