"""What the import-linter contracts in pyproject.toml cannot see: which OpenCV calls a module makes.

cv2 is imported by perception (ArUco detection and rendering on images) and by the camera adapter; opening a
device or a video (``cv2.VideoCapture``) is hardware access and belongs to the adapters. The one exception is
``masonry perception estimate``, which reads a video file or a live camera itself.
"""

from __future__ import annotations

import ast
from pathlib import Path

import masonry

PACKAGE = Path(masonry.__file__).parent
CAPTURE_ALLOWED = {"adapters/camera.py", "cli/perception.py"}


def _captures(path: Path) -> list[int]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute) and node.attr in {"VideoCapture", "VideoWriter"}
    ]


def test_only_the_camera_adapter_and_the_estimate_command_open_a_capture() -> None:
    found = {
        path.relative_to(PACKAGE).as_posix(): lines
        for path in sorted(PACKAGE.rglob("*.py"))
        if (lines := _captures(path))
    }
    assert found, "the camera adapter opens a VideoCapture: the scan found none, so it is broken"
    outside = {name: lines for name, lines in found.items() if name not in CAPTURE_ALLOWED}
    assert not outside, f"cv2 capture outside the adapters (module: lines): {outside}"


def test_the_scan_sees_a_capture(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text("import cv2\n\ndef f():\n    return cv2.VideoCapture(0)\n", encoding="utf-8")
    assert _captures(probe) == [4]
