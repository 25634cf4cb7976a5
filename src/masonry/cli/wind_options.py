"""``--wind`` and ``--turbulence`` (``masonry sim``, ``masonry fly --sim``): the simulated site's wind."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import typer

from masonry.errors import InputError

if TYPE_CHECKING:
    from masonry.sim.faults import Faults

__all__ = ["TURBULENCE_OPTION", "WIND_OPTION", "site_faults"]

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
    from masonry.sim.wind import WindConfig, parse_turbulence, parse_wind

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
