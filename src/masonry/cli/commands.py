"""Imports each command module once so its commands register on the app (order = order in --help)."""

from __future__ import annotations

import importlib

_MODULES = (
    "plan",  # masonry plan, schema, blueprint
    "sim",  # masonry sim
    "schedule",  # masonry schedule
    "mission",  # masonry mission-control
    "perception",  # masonry estimate, markers, calibrate
    "fly",  # masonry fly
    "replay",  # masonry replay
    "ctl",  # masonry ctl
    "fsm",  # masonry fsm diagram
    "hardware",  # masonry sitl
)

for _name in _MODULES:
    importlib.import_module(f"masonry.cli.{_name}")
