"""The JSON Schema of the blueprint format (``masonry schema`` prints it for editors and validators).

The schema checks structure and types; geometric rules (interpenetration, support, pickups of unplaced bricks,
fleet roles) are checked by :func:`masonry.blueprint.parse_blueprint`, which is the authority.
"""

from __future__ import annotations

from typing import Any

from masonry.blueprint import (
    ARUCO_DICTIONARIES,
    DEFAULT_BRICK_SIZE_M,
    DEFAULT_CLEARANCE_M,
    DEFAULT_CRUISE_ALTITUDE_M,
)

SCHEMA_ID = "https://masonry.example/schemas/blueprint.schema.json"


def _vec3(description: str) -> dict[str, Any]:
    return {
        "type": "array",
        "items": {"type": "number"},
        "minItems": 3,
        "maxItems": 3,
        "description": description,
    }


def _size(description: str) -> dict[str, Any]:
    return {
        "type": "array",
        "items": {"type": "number", "exclusiveMinimum": 0},
        "minItems": 3,
        "maxItems": 3,
        "description": description,
    }


def blueprint_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a blueprint file."""
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": SCHEMA_ID,
        "title": "masonry wall blueprint",
        "description": "Bricks of a wall, their pickup points and the UAV fleet (see docs/blueprint-format.md).",
        "type": "object",
        "additionalProperties": False,
        "required": ["bricks", "fleet"],
        "properties": {
            "name": {"type": "string", "description": "Name of the wall."},
            "clearance": {
                "type": "number",
                "exclusiveMinimum": 0,
                "default": DEFAULT_CLEARANCE_M,
                "description": "Minimum clearance r_c between UAVs, metres.",
            },
            "cruise_altitude": {
                "type": "number",
                "exclusiveMinimum": 0,
                "default": DEFAULT_CRUISE_ALTITUDE_M,
                "description": "Cruise altitude of the UAVs, metres.",
            },
            "brick": {
                "type": "object",
                "additionalProperties": False,
                "description": "Defaults for every brick.",
                "properties": {
                    "size": {
                        **_size("Length (along the brick's x axis), width, height, metres."),
                        "default": list(DEFAULT_BRICK_SIZE_M),
                    },
                    "markers": {
                        "type": "object",
                        "additionalProperties": False,
                        "description": "ArUco markers 2k and 2k+1 on brick k's top face, on its length axis.",
                        "properties": {
                            "dictionary": {"enum": list(ARUCO_DICTIONARIES), "default": "DICT_4X4_50"},
                            "size": {"type": "number", "exclusiveMinimum": 0, "default": 0.05,
                                     "description": "Marker side, metres."},
                            "spacing": {"type": "number", "exclusiveMinimum": 0, "default": 0.175,
                                        "description": "Distance between the two marker centres, metres."},
                        },
                    },
                },
            },
            "bricks": {
                "type": "array",
                "minItems": 1,
                "items": {
                    "type": "object",
                    "additionalProperties": False,
                    "required": ["id", "position"],
                    "properties": {
                        "id": {"type": "integer", "minimum": 0, "description": "Unique brick id."},
                        "position": _vec3("Geometric centre of the brick, world ENU frame, metres."),
                        "yaw": {"type": "number", "default": 0.0,
                                "description": "Rotation of the brick's length axis about z, radians."},
                        "placed": {"type": "boolean", "default": False,
                                   "description": "Already in place when the mission starts."},
                        "size": _size("Per-brick override of brick.size, metres."),
                        "pickup": _vec3("Approximate centre of the brick at its pickup site (required unless placed)."),
                    },
                },
            },
            "fleet": {
                "type": "array",
                "items": {
                    "type": "object",
                    "additionalProperties": False,
                    "required": ["name", "role", "home"],
                    "properties": {
                        "name": {"type": "string", "minLength": 1},
                        "role": {"enum": ["brick", "adhesion"]},
                        "home": _vec3("Take-off and landing point, metres."),
                    },
                },
            },
        },
    }
