"""Camera calibration: FileStorage YAML round trip, clear errors, chessboard calibration on synthetic views."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from masonry.errors import InputError
from masonry.perception.calibration import (
    ChessboardSpec,
    calibrate_chessboard,
    parse_board,
    read_calibration,
    write_calibration,
)
from masonry.perception.types import CameraIntrinsics

TRUE = CameraIntrinsics(610.0, 605.0, 322.0, 236.0, width_px=640, height_px=480)


def chessboard_view(
    board: ChessboardSpec, intr: CameraIntrinsics, rvec: np.ndarray, tvec: np.ndarray
) -> np.ndarray:
    """A grey image of ``board`` (one white square of margin) seen by a distortion-free camera."""
    p = 24  # texture pixels per square
    nx, ny = board.cols + 1 + 2, board.rows + 1 + 2
    yy, xx = np.mgrid[0 : ny * p, 0 : nx * p]
    tex = np.where(((xx // p) + (yy // p)) % 2 == 0, 30, 225).astype(np.uint8)
    margin = (xx < p) | (yy < p) | (xx >= (nx - 1) * p) | (yy >= (ny - 1) * p)
    tex[margin] = 225
    s = board.square_m / p
    A = np.array([[s, 0.0, (0.5 - 2 * p) * s], [0.0, s, (0.5 - 2 * p) * s], [0.0, 0.0, 1.0]])
    R = cv2.Rodrigues(rvec)[0]
    H = intr.matrix() @ np.column_stack([R[:, 0], R[:, 1], tvec]) @ A
    img = cv2.warpPerspective(tex, H, (intr.width_px, intr.height_px), borderValue=120)
    return cv2.GaussianBlur(img, (0, 0), 0.7)


def views(board: ChessboardSpec, count: int = 8) -> list[tuple[str, np.ndarray]]:
    rng = np.random.default_rng(3)
    out = []
    for i in range(count):
        rvec = np.array([rng.uniform(-0.45, 0.45), rng.uniform(-0.45, 0.45), rng.uniform(-0.3, 0.3)])
        centre = np.array([(board.cols - 1) * board.square_m / 2, (board.rows - 1) * board.square_m / 2, 0.0])
        R = cv2.Rodrigues(rvec)[0]
        tvec = (
            np.array([rng.uniform(-0.03, 0.03), rng.uniform(-0.03, 0.03), rng.uniform(0.45, 0.6)])
            - R @ centre
        )
        out.append((f"view{i}.png", chessboard_view(board, TRUE, rvec, tvec)))
    return out


def test_chessboard_calibration_recovers_the_camera() -> None:
    board = ChessboardSpec(9, 6, 0.025)
    result = calibrate_chessboard(views(board), board)
    assert len(result.used) >= 6
    intr = result.intrinsics
    assert intr.fx == pytest.approx(TRUE.fx, rel=0.02)
    assert intr.fy == pytest.approx(TRUE.fy, rel=0.02)
    assert intr.cx == pytest.approx(TRUE.cx, abs=6.0)
    assert intr.cy == pytest.approx(TRUE.cy, abs=6.0)
    assert result.rms_px < 0.5
    assert (intr.width_px, intr.height_px) == (640, 480)


def test_wrong_board_size_is_a_clear_error() -> None:
    board = ChessboardSpec(9, 6, 0.025)
    # two views: OpenCV's search for a board that is not there takes most of a second per image
    with pytest.raises(InputError, match=r"7x5 chessboard was found in 0 of 2 images"):
        calibrate_chessboard(views(board, count=2), ChessboardSpec(7, 5, 0.025))


def test_yaml_round_trip(tmp_path: Path) -> None:
    intr = CameraIntrinsics(600.5, 601.25, 319.0, 241.5, (-0.1, 0.02, 0.001, -0.002, 0.003), 800, 600)
    path = tmp_path / "camera.yaml"
    write_calibration(path, intr, rms_px=0.3, image_count=12)
    text = path.read_text()
    assert text.startswith("%YAML")  # "%YAML 1.2" from OpenCV 5, "%YAML:1.0" from 4.x
    assert "camera_matrix: !!opencv-matrix" in text
    assert read_calibration(path) == intr


def test_reads_opencv_sample_key_spellings(tmp_path: Path) -> None:
    path = tmp_path / "cam.yml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("cameraMatrix", np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]]))
    fs.write("dist_coeffs", np.zeros((5, 1)))
    fs.release()
    intr = read_calibration(path)
    assert (intr.fx, intr.cx, intr.width_px, intr.height_px) == (500.0, 320.0, 640, 480)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("%YAML:1.0\nimage_width: 640\n", "no camera_matrix"),
        ("this is : not [ yaml", "not an OpenCV FileStorage|cannot open|no camera_matrix"),
        (
            (
                "%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                "   data: [ -5., 0., 320., 0., 500., 240., 0., 0., 1. ]\n"
            ),
            "fx, fy > 0",
        ),
    ],
)
def test_bad_calibration_files_are_clear_errors(tmp_path: Path, content: str, message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    with pytest.raises(InputError, match=message) as info:
        read_calibration(path)
    assert str(path) in str(info.value)


def test_missing_calibration_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="calibration file not found"):
        read_calibration(tmp_path / "nope.yaml")


@pytest.mark.parametrize(
    "text",
    ["chessboard:9x6", "board:9x6:0.025", "chessboard:2x6:0.025", "chessboard:9x6:0", "chessboard:9x6:2"],
)
def test_bad_board_specs(text: str) -> None:
    from masonry.cli.app import cli_message

    with pytest.raises(InputError, match=r"^`board`: ") as info:
        parse_board(text)
    assert info.value.options == ("board",) and cli_message(info.value).startswith(
        "--board: "
    )  # the CLI's term


def test_board_spec() -> None:
    board = parse_board("chessboard:9x6:0.025")
    assert board == ChessboardSpec(9, 6, 0.025)
    pts = board.object_points()
    assert pts.shape == (54, 3)
    assert math.isclose(float(pts[1, 0]), 0.025, rel_tol=1e-6)
    assert math.isclose(float(pts[9, 1]), 0.025, rel_tol=1e-6)
