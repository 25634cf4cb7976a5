"""Fault injection for the simulated world: each fault is one knob, settable from the command line.

``Faults.parse(["grasp=0.3", "uav-loss=brick-2@120"])`` reads the ``--fault KEY=VALUE`` options of
``masonry sim`` / ``masonry fly --sim``. Keys:

============  ==================  ===============================================================
key           value               effect
============  ==================  ===============================================================
grasp         probability [0, 1]  an attach attempt fails (magnet on, touching, nothing attached)
dropout       probability [0, 1]  a whole camera frame carries no marker observation
occlusion     probability [0, 1]  in a frame, one marker of every brick is hidden
gusts         m/s >= 0            turbulence of this horizontal intensity (see below)
battery       1/s >= 0            battery drain while airborne, fraction of a full pack per second
link-loss     NAME@SECONDS        the UAV's autopilot link goes silent at that simulated time
uav-loss      NAME@SECONDS        the UAV fails (falls, disarms) at that simulated time
============  ==================  ===============================================================

The wind itself (``--wind SPEED[@DIR_DEG]``, ``--turbulence LEVEL|M/S``) is :attr:`Faults.wind`, a
:class:`masonry.sim.wind.WindConfig`. ``gusts=S`` is kept for old command lines: it is Dryden turbulence of
horizontal intensity S m/s (``--turbulence S``) in whatever mean wind ``--wind`` gives; with ``--turbulence``
as well it is refused (one of the two). Before the wind model it was an Ornstein-Uhlenbeck gust of standard
deviation S and a 2 s correlation time, with no mean wind.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType
from typing import Any

from masonry.errors import InputError
from masonry.sim.wind import WindConfig

__all__ = ["FAULT_KEYS", "Faults"]

FAULT_KEYS: tuple[str, ...] = ("grasp", "dropout", "occlusion", "gusts", "battery", "link-loss", "uav-loss")

_ALIASES = {
    "grasp-failure": "grasp",
    "gust": "gusts",
    "battery-drain": "battery",
    "link": "link-loss",
    "uav": "uav-loss",
}
_SCALAR_FIELD = {
    "grasp": "grasp_failure",
    "dropout": "dropout",
    "occlusion": "occlusion",
    "gusts": "gusts_mps",
    "battery": "battery_drain_per_s",
}
_TIMED_FIELD = {"link-loss": "link_loss_at_s", "uav-loss": "uav_loss_at_s"}
_PROBABILITIES = ("grasp_failure", "dropout", "occlusion")
#: Upper bounds of the other scalar faults: beyond them the value can only be a typing mistake (gusts of
#: 1e6 m/s, a pack drained in a millisecond). 15 m/s gusts (std) ground any small UAV already.
MAX_GUSTS_MPS = 15.0
MAX_BATTERY_DRAIN_PER_S = 1.0  # a full pack in 1 s (tests drain one in 5 s)


@dataclass(frozen=True)
class Faults:
    """The faults injected into a simulated world (all off by default).

    Attributes:
        grasp_failure: probability that an attach attempt fails although the magnet touches the brick.
        dropout: probability that a camera frame carries no marker observation at all.
        occlusion: probability that, in a frame, one marker (chosen at random) of every brick is hidden.
        gusts_mps: standard deviation of the horizontal wind gusts, m/s (0: still air).
        link_loss_at_s: UAV name -> simulated time at which its autopilot link is lost for good.
        battery_drain_per_s: battery drain while airborne (fraction of a full pack per second); None keeps the
            vehicle's own figure (``VehicleConfig.battery_drain_per_s``).
        uav_loss_at_s: UAV name -> simulated time at which the UAV fails (motors stop, it falls).
        wind: the site's mean wind and turbulence (default: still air).
    """

    grasp_failure: float = 0.0
    dropout: float = 0.0
    occlusion: float = 0.0
    gusts_mps: float = 0.0
    link_loss_at_s: Mapping[str, float] = field(default_factory=dict)
    battery_drain_per_s: float | None = None
    uav_loss_at_s: Mapping[str, float] = field(default_factory=dict)
    wind: WindConfig = field(default_factory=WindConfig)

    def __post_init__(self) -> None:
        for name in _PROBABILITIES:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0.0 <= value <= 1.0):
                raise InputError(f"fault {name}: a probability must be in [0, 1], got {value!r}")
        if not (
            isinstance(self.gusts_mps, (int, float))
            and math.isfinite(self.gusts_mps)
            and 0 <= self.gusts_mps <= MAX_GUSTS_MPS
        ):
            raise InputError(
                f"fault gusts_mps: must be a speed from 0 to {MAX_GUSTS_MPS:g} m/s, got {self.gusts_mps!r}"
            )
        if not isinstance(self.wind, WindConfig):
            raise InputError(f"fault wind: a WindConfig, got {self.wind!r}")
        if self.gusts_mps > 0 and self.wind.turbulence != "none":
            raise InputError(
                f"fault gusts={self.gusts_mps:g} and turbulence {self.wind.turbulence}: give one of the two "
                "(gusts=S is turbulence of intensity S)"
            )
        drain = self.battery_drain_per_s
        if drain is not None and not (
            isinstance(drain, (int, float)) and math.isfinite(drain) and 0 <= drain <= MAX_BATTERY_DRAIN_PER_S
        ):
            raise InputError(
                f"fault battery_drain_per_s: must be a rate from 0 to {MAX_BATTERY_DRAIN_PER_S:g} per second, "
                f"got {drain!r}"
            )
        for name in ("link_loss_at_s", "uav_loss_at_s"):
            table = dict(getattr(self, name))
            for uav, at_s in table.items():
                if not isinstance(uav, str) or not uav:
                    raise InputError(f"fault {name}: UAV names must be non-empty strings, got {uav!r}")
                if not (isinstance(at_s, (int, float)) and math.isfinite(at_s) and at_s >= 0):
                    raise InputError(f"fault {name}[{uav}]: the time must be finite and >= 0 s, got {at_s!r}")
            object.__setattr__(self, name, MappingProxyType({k: float(v) for k, v in table.items()}))

    def __hash__(self) -> int:
        return hash(
            tuple(
                tuple(sorted(v.items())) if isinstance(v, Mapping) else v
                for v in (getattr(self, f.name) for f in fields(self))
            )
        )

    @property
    def any(self) -> bool:
        """True when at least one fault is on."""
        return self != Faults()

    def site_wind(self) -> WindConfig:
        """The wind the world blows: :attr:`wind`, with ``gusts`` as its turbulence intensity."""
        if self.gusts_mps > 0:
            return replace(self.wind, turbulence="custom", turbulence_mps=self.gusts_mps)
        return self.wind

    def uav_names(self) -> frozenset[str]:
        """Every UAV name a timed fault refers to."""
        return frozenset(self.link_loss_at_s) | frozenset(self.uav_loss_at_s)

    def check_uavs(self, names: Iterable[str]) -> None:
        """Raise InputError if a timed fault names a UAV that is not among ``names``."""
        known = set(names)
        for table, key in ((self.link_loss_at_s, "link-loss"), (self.uav_loss_at_s, "uav-loss")):
            for uav in table:
                if uav not in known:
                    raise InputError(
                        f"fault {key}={uav}@{table[uav]:g}: no UAV named {uav!r} (fleet: {', '.join(sorted(known))})"
                    )

    @classmethod
    def mild(cls, rng: random.Random) -> Faults:
        """Random mild faults of the kinds a site always has (grasp misses, dropped and occluded frames, light
        gusts), each present half the time: for property tests and sweeps over random layouts."""
        spec = []
        if rng.random() < 0.5:
            spec.append(f"grasp={rng.uniform(0.0, 0.2):.2f}")
        if rng.random() < 0.5:
            spec.append(f"dropout={rng.uniform(0.0, 0.3):.2f}")
        if rng.random() < 0.5:
            spec.append(f"occlusion={rng.uniform(0.0, 0.3):.2f}")
        if rng.random() < 0.3:
            spec.append(f"gusts={rng.uniform(0.0, 0.5):.2f}")
        return cls.parse(spec)

    @classmethod
    def parse(cls, items: Iterable[str], base: Faults | None = None) -> Faults:
        """Build Faults from ``KEY=VALUE`` strings (``--fault`` options), on top of ``base``.

        Args:
            items: e.g. ``["grasp=0.3", "dropout=0.5", "gusts=2.0", "uav-loss=brick-2@120"]``.
            base: faults to start from (default: none).

        Raises:
            InputError: an item is malformed, its key unknown, its value out of range, or a key given twice.
        """
        changes: dict[str, Any] = {}
        timed: dict[str, dict[str, float]] = {
            f: dict(getattr(base, f)) if base else {} for f in _TIMED_FIELD.values()
        }
        seen: set[str] = set()
        for item in items:
            text = str(item).strip()
            key, sep, value = text.partition("=")
            key = key.strip().lower().replace("_", "-")
            value = value.strip()
            if not sep or not key or not value:
                raise InputError(
                    f"fault {text!r}: expected KEY=VALUE with KEY one of {', '.join(FAULT_KEYS)}"
                )
            key = _ALIASES.get(key, key)
            if key in _SCALAR_FIELD:
                if key in seen:
                    raise InputError(f"fault {text!r}: {key} is given twice")
                seen.add(key)
                number = _number(text, key, value)
                name = _SCALAR_FIELD[key]
                if name in _PROBABILITIES and not 0.0 <= number <= 1.0:
                    raise InputError(f"fault {text!r}: {key} is a probability and must be in [0, 1]")
                if number < 0.0:
                    raise InputError(f"fault {text!r}: {key} must be >= 0")
                high = {"gusts": MAX_GUSTS_MPS, "battery": MAX_BATTERY_DRAIN_PER_S}.get(key)
                if high is not None and number > high:
                    raise InputError(
                        f"fault {text!r}: {key} must be at most {high:g}"
                        f"{' m/s' if key == 'gusts' else ' per second'}"
                    )
                changes[name] = number
            elif key in _TIMED_FIELD:
                uav, at, when = value.rpartition("@")
                uav = uav.strip()
                if not at or not uav:
                    raise InputError(f"fault {text!r}: {key} expects NAME@SECONDS, e.g. {key}=brick-2@120")
                at_s = _number(text, key, when.strip())
                if at_s < 0.0:
                    raise InputError(f"fault {text!r}: the time must be >= 0 s")
                table = timed[_TIMED_FIELD[key]]
                if f"{key}:{uav}" in seen:
                    raise InputError(f"fault {text!r}: {key} is given twice for {uav}")
                seen.add(f"{key}:{uav}")
                table[uav] = at_s
            else:
                raise InputError(f"fault {text!r}: unknown key {key!r} (known: {', '.join(FAULT_KEYS)})")
        for name, table in timed.items():
            changes[name] = table
        return replace(base if base is not None else cls(), **changes)


def _number(text: str, key: str, value: str) -> float:
    try:
        number = float(value)
    except ValueError:
        raise InputError(f"fault {text!r}: {key} needs a number, got {value!r}") from None
    if not math.isfinite(number):
        raise InputError(f"fault {text!r}: {key} needs a finite number, got {value!r}")
    return number
