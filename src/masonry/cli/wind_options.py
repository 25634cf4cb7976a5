"""``--wind`` and ``--turbulence`` (``masonry sim``, ``masonry fly --sim``): the simulated site's wind."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import typer

from masonry.errors import InputError

if TYPE_CHECKING:
    from masonry.sim.faults import Faults

__all__ = ["TURBULENCE_OPTION", "WIND_OPTION", "parse_turbulence", "parse_wind", "site_faults"]

WIND_OPTION = typer.Option(
    None,
    "--wind",
    metavar="SPEED[@DIR_DEG]",
    help="Mean wind of the simulated site: m/s at 10 m (a forecast's height; less lower down, power law), "
    "blowing from DIR_DEG clockwise from north (+y), e.g. 4@270 (docs/simulator.md).",
)
TURBULENCE_OPTION = typer.Option(
    None,
    "--turbulence",
    metavar="LEVEL|M/S",
    help="Dryden turbulence (MIL-F-8785C, low altitude): light | moderate | severe | none, or the horizontal "
    "intensity in m/s. --fault gusts=S is --turbulence S.",
)


def site_faults(fault: list[str], wind: str | None, turbulence: str | None) -> Faults:
    """The ``--fault`` options with the ``--wind`` and ``--turbulence`` ones (InputError, one line, if bad)."""
    from masonry.sim.faults import Faults  # the simulator on demand: the CLI starts fast
    from masonry.sim.wind import WindConfig

    faults = Faults.parse(fault)
    if wind is None and turbulence is None:
        return faults
    speed, direction = parse_wind(wind) if wind is not None else (0.0, 0.0)
    level, sigma = parse_turbulence(turbulence) if turbulence is not None else ("none", 0.0)
    if faults.gusts_mps > 0 and level != "none":
        raise InputError(
            f"--turbulence {turbulence} and --fault gusts={faults.gusts_mps:g}: give one of the two "
            "(gusts=S is --turbulence S)"
        )
    return replace(
        faults,
        wind=WindConfig(speed_mps=speed, direction_deg=direction, turbulence=level, turbulence_mps=sigma),
    )


_MAX_WIND_MPS = 30.0  # masonry.sim.wind.MAX_WIND_MPS
_MAX_TURBULENCE_MPS = 15.0  # masonry.sim.wind.MAX_TURBULENCE_MPS


def _levels() -> tuple[str, ...]:
    return ("light", "moderate", "severe")


def parse_wind(text: str) -> tuple[float, float]:
    """``--wind SPEED[@DIR_DEG]`` -> (speed m/s, direction deg); InputError (one line) otherwise."""
    raw = str(text).strip()
    speed_s, at, dir_s = raw.partition("@")
    if at and not dir_s.strip():
        raise InputError(f"--wind {raw!r}: a direction in degrees after @, e.g. 4@270")
    try:
        speed = float(speed_s)
        direction = float(dir_s) if at else 0.0
    except ValueError:
        raise InputError(
            f"--wind {raw!r}: expected SPEED[@DIR_DEG], e.g. 4 or 4@270 (m/s, from degrees clockwise from north)"
        ) from None
    if not (math.isfinite(speed) and 0.0 <= speed <= _MAX_WIND_MPS):
        raise InputError(f"--wind {raw!r}: the speed must be from 0 to {_MAX_WIND_MPS:g} m/s")
    if not (math.isfinite(direction) and -360.0 <= direction <= 360.0):
        raise InputError(f"--wind {raw!r}: the direction must be from -360 to 360 degrees")
    return speed, direction


def parse_turbulence(text: str) -> tuple[str, float]:
    """``--turbulence light|moderate|severe|none|<m/s>`` -> (level, sigma_u for a number); InputError otherwise."""
    raw = str(text).strip().lower()
    if raw in _levels() or raw == "none":
        return raw, 0.0
    try:
        sigma = float(raw)
    except ValueError:
        raise InputError(
            f"--turbulence {text!r}: expected light, moderate, severe, none or an intensity in m/s"
        ) from None
    if not (math.isfinite(sigma) and 0.0 <= sigma <= _MAX_TURBULENCE_MPS):
        raise InputError(
            f"--turbulence {text!r}: the intensity must be from 0 to {_MAX_TURBULENCE_MPS:g} m/s"
        )
    return "custom", sigma
