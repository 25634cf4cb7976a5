"""Guards on the public surface: a sorted, importable ``__all__`` and a light ``masonry`` import."""

from __future__ import annotations

import subprocess
import sys

import masonry


def _isort_key(name: str) -> tuple[int, str]:
    """ruff's RUF022 order: CONSTANTS, then Classes, then functions, each alphabetical."""
    kind = 0 if name.isupper() else 1 if name[:1].isupper() else 2
    return (kind, name)


def test_all_is_sorted_and_unique() -> None:
    assert list(masonry.__all__) == sorted(set(masonry.__all__), key=_isort_key)


def test_every_public_name_resolves() -> None:
    missing = [name for name in masonry.__all__ if not hasattr(masonry, name)]
    assert missing == []


def test_error_tree_has_one_root() -> None:
    from masonry import errors

    classes = [obj for obj in vars(errors).values() if isinstance(obj, type) and issubclass(obj, Exception)]
    assert all(issubclass(cls, errors.MasonryError) for cls in classes)


def test_cli_help_does_not_import_heavy_libraries() -> None:
    code = (
        "import sys; from masonry.cli import app; "
        "heavy = [m for m in ('cv2', 'matplotlib', 'pymavlink', 'zenoh', 'scipy', 'foxglove', 'mcap') if m in sys.modules]; "
        "print(','.join(heavy))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
