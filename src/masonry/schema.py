"""The JSON Schema of the blueprint format (``masonry schema`` prints it for editors and validators).

The schema checks structure, types and the per-value limits (site size, brick size, clearance, UAV names);
geometric rules (interpenetration, support fraction, pickups of unplaced bricks, pickups and homes off the wall,
marker ids within the dictionary, fleet roles) are checked by :func:`masonry.blueprint.parse_blueprint`, which is
the authority.
"""

from __future__ import annotations

from typing import Any

from masonry.blueprint import (
    ARUCO_DICTIONARIES,
    ARUCO_DICTIONARY_SIZES,
    DEFAULT_BRICK_SIZE_M,
    DEFAULT_CLEARANCE_M,
    DEFAULT_CRUISE_ALTITUDE_M,
    MAX_ABS_YAW_RAD,
    MAX_BRICK_DIMENSION_M,
    MAX_BRICK_ID,
    MAX_CLEARANCE_M,
    MAX_HOME_HEIGHT_M,
    MAX_PICKUP_HEIGHT_M,
    RESERVED_UAV_NAMES,
    RESTING_TOL_M,
    SITE_HALF_EXTENT_M,
    SITE_MAX_HEIGHT_M,
    UAV_NAME_PATTERN,
)
from masonry.geofence import MAX_BOUNDARY_VERTICES
from masonry.placement_check import MAX_AS_BUILT_PULLBACK_M, MAX_PLACEMENT_TOLERANCE_M, ON_PLACEMENT_ERROR

SCHEMA_ID = "https://masonry.example/schemas/blueprint.schema.json"


def _vec3(description: str, max_z_m: float, min_z_m: float | None = None) -> dict[str, Any]:
    xy = {"type": "number", "minimum": -SITE_HALF_EXTENT_M, "maximum": SITE_HALF_EXTENT_M}
    z = {"type": "number", "minimum": -max_z_m if min_z_m is None else min_z_m, "maximum": max_z_m}
    return {
        "type": "array",
        "prefixItems": [xy, xy, z],
        "items": False,
        "minItems": 3,
        "maxItems": 3,
        "description": description,
    }


def _size(description: str) -> dict[str, Any]:
    return {
        "type": "array",
        "items": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_BRICK_DIMENSION_M},
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
                "maximum": MAX_CLEARANCE_M,
                "default": DEFAULT_CLEARANCE_M,
                "description": "Minimum clearance r_c between UAVs, metres.",
            },
            "cruise_altitude": {
                "type": "number",
                "exclusiveMinimum": 0,
                "maximum": SITE_MAX_HEIGHT_M,
                "default": DEFAULT_CRUISE_ALTITUDE_M,
                "description": "Cruise altitude of the UAVs, metres (above the finished wall's top).",
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
                            "size": {
                                "type": "number",
                                "exclusiveMinimum": 0,
                                "default": 0.05,
                                "description": "Marker side, metres.",
                            },
                            "spacing": {
                                "type": "number",
                                "exclusiveMinimum": 0,
                                "default": 0.175,
                                "description": "Distance between the two marker centres, metres.",
                            },
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
                        "id": {
                            "type": "integer",
                            "minimum": 0,
                            "maximum": MAX_BRICK_ID,
                            "description": "Unique brick id; its marker number unless `marker` is given.",
                        },
                        "position": _vec3(
                            "Geometric centre of the brick, world ENU frame, metres.", SITE_MAX_HEIGHT_M
                        ),
                        "yaw": {
                            "type": "number",
                            "default": 0.0,
                            "minimum": -MAX_ABS_YAW_RAD,
                            "maximum": MAX_ABS_YAW_RAD,
                            "description": "Rotation of the brick's length axis about z, radians.",
                        },
                        "placed": {
                            "type": "boolean",
                            "default": False,
                            "description": "Already in place when the mission starts.",
                        },
                        "size": _size("Per-brick override of brick.size, metres."),
                        "pickup": _vec3(
                            "Approximate centre of the brick at its pickup site (required unless placed).",
                            MAX_PICKUP_HEIGHT_M,
                        ),
                        "marker": {
                            "type": "integer",
                            "minimum": 0,
                            "maximum": max(ARUCO_DICTIONARY_SIZES.values()) // 2 - 1,
                            "description": "Marker number m (ArUco ids 2m, 2m+1; default: the id), reused only "
                            "by bricks no camera sees together.",
                        },
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
                        "name": {
                            "type": "string",
                            "pattern": f"^{UAV_NAME_PATTERN}$",
                            "not": {"enum": list(RESERVED_UAV_NAMES)},
                            "description": "Part of the mission's Zenoh keys.",
                        },
                        "role": {"enum": ["brick", "adhesion"]},
                        "home": _vec3(
                            "Take-off and landing point, metres.", MAX_HOME_HEIGHT_M, -RESTING_TOL_M
                        ),
                    },
                },
            },
            "site": _site(),
            "adhesive": _adhesive(),
            "spares": {
                "type": "array",
                "description": 'Spare bricks (absent: no spare accounting; docs/blueprint-format.md, "Spares").',
                "items": {
                    "type": "object",
                    "additionalProperties": False,
                    "required": ["id", "pickup"],
                    "properties": {
                        "id": {
                            "type": "integer",
                            "minimum": 0,
                            "maximum": max(ARUCO_DICTIONARY_SIZES.values()) // 2 - 1,
                            "description": "Unique among bricks and spares; the spare carries markers 2k, 2k+1.",
                        },
                        "pickup": _vec3(
                            "Approximate centre of the spare where it waits, metres.", MAX_PICKUP_HEIGHT_M
                        ),
                        "size": _size(
                            "The spare's size (default brick.size); it stands in for bricks of this size."
                        ),
                    },
                },
            },
            "placement_tolerance_m": {
                "type": "number",
                "exclusiveMinimum": 0,
                "maximum": MAX_PLACEMENT_TOLERANCE_M,
                "description": "A placed brick whose as-built centre is farther than this from its design is an "
                "event the operator sees (m; default 0.02).",
            },
            "on_placement_error": {
                "enum": list(ON_PLACEMENT_ERROR),
                "description": "What the mission does when a brick is beyond placement_tolerance_m: continue "
                "(default) or hold (pause until the operator resumes).",
            },
            "plan_on_as_built": {
                "type": "boolean",
                "description": "Plan on what was built: a brick's target keeps its designed offsets to the "
                "as-built bricks under it (pulled back toward the design by as_built_pullback_m per course, never "
                "farther than placement_tolerance_m), an adhesion segment moves with the bricks it joins "
                "(default false).",
            },
            "as_built_pullback_m": {
                "type": "number",
                "minimum": 0,
                "maximum": MAX_AS_BUILT_PULLBACK_M,
                "description": "How much nearer its design each course's target is brought (m; default 0.005).",
            },
        },
    }


def _adhesive() -> dict[str, Any]:
    """The optional ``adhesive`` (open and cure times; docs/blueprint-format.md, "Adhesive")."""
    from masonry.adhesive import MAX_ADHESIVE_TIME_S

    return {
        "type": "object",
        "additionalProperties": False,
        "minProperties": 1,
        "description": "The adhesive's open time and cure time (absent: neither is modelled).",
        "properties": {
            "open_time_s": {
                "type": "number",
                "exclusiveMinimum": 0,
                "maximum": MAX_ADHESIVE_TIME_S,
                "description": "A brick starts its flight down onto a bead within this time of the bead's spraying (s).",
            },
            "cure_time_s": {
                "type": "number",
                "minimum": 0,
                "maximum": MAX_ADHESIVE_TIME_S,
                "description": "Nothing is sprayed onto a brick before this time has passed since it was placed (s).",
            },
        },
    }


def _site() -> dict[str, Any]:
    """The optional ``site`` (the geofence; docs/blueprint-format.md, "Site")."""
    xy = {"type": "number", "minimum": -SITE_HALF_EXTENT_M, "maximum": SITE_HALF_EXTENT_M}
    return {
        "type": "object",
        "additionalProperties": False,
        "required": ["boundary", "max_altitude"],
        "description": "The site's geofence: the UAVs never fly outside it (a simple polygon, either orientation; "
        "the wall, pickups and homes at least 1 m inside).",
        "properties": {
            "boundary": {
                "type": "array",
                "minItems": 3,
                "maxItems": MAX_BOUNDARY_VERTICES,
                "items": {
                    "type": "array",
                    "prefixItems": [xy, xy],
                    "items": False,
                    "minItems": 2,
                    "maxItems": 2,
                },
                "description": "Vertices [x, y] of the boundary polygon, world ENU frame, metres (not closed).",
            },
            "max_altitude": {
                "type": "number",
                "exclusiveMinimum": 0,
                "maximum": SITE_HALF_EXTENT_M,
                "description": "Altitude limit, metres (0.5 m above the highest transit layer at least).",
            },
        },
    }
