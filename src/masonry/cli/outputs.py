"""Output files of the commands: checked before the work starts, written atomically.

Every option that names a file a command writes (``--report``, ``--gantt``, ``--plot3d``, ``--output``/``-o``,
``--graph``, ...) goes through :func:`check_output_path` before the command does any work, so that a long
simulation never ends in a traceback because its report cannot be written; and the file is written through
:func:`write_atomic` or :func:`atomic_path` (a temporary file in the same directory, then ``os.replace``), so a
crash or a full disk never leaves a half-written file in place of a good one.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from masonry.errors import InputError


def check_output_path(path: Path | str | None, flag: str) -> Path | None:
    """Check that ``path`` can be written as the output of ``flag``; return it as a Path (None stays None).

    The path must not be a directory, its directory must exist and be a writable directory, and an existing
    file there must be writable.

    Raises:
        InputError: one line naming the flag, the path and what is wrong.
    """
    if path is None:
        return None
    p = Path(path)
    where = f"{flag} {p}"
    if str(p) in ("", "."):
        raise InputError(f"{flag}: empty file name")
    if p.is_dir():
        raise InputError(f"{where}: is a directory, not a file")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.exists():
        raise InputError(f"{where}: the directory {parent} does not exist")
    if not parent.is_dir():
        raise InputError(f"{where}: {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{where}: the directory {parent} is not writable")
    if p.exists() and not p.is_file():
        raise InputError(f"{where}: exists and is not a regular file")
    if p.exists() and (not os.access(p, os.W_OK) or not p.stat().st_mode & 0o222):
        raise InputError(f"{where}: the file is read-only")
    return p


def check_output_paths(outputs: Iterable[tuple[str, Path | str | None]]) -> None:
    """:func:`check_output_path` for each (flag, path); also refuses two flags naming the same file."""
    seen: dict[str, str] = {}
    for flag, path in outputs:
        p = check_output_path(path, flag)
        if p is None:
            continue
        key = os.path.realpath(p)
        if key in seen:
            raise InputError(f"{flag} {p}: the same file as {seen[key]}")
        seen[key] = flag


@contextlib.contextmanager
def atomic_path(path: Path | str, flag: str = "output") -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix) to write; on success it replaces ``path``.

    On an exception the temporary file is removed and ``path`` is left as it was. A write that fails with an
    OSError is reported as an :class:`InputError` naming ``flag`` and ``path``.
    """
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{p.stem}.", suffix=f".tmp{p.suffix}", dir=parent)
    except OSError as exc:
        raise InputError(f"{flag} {p}: cannot write ({exc.strerror or exc})") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        mode = 0o666 & ~_umask()
        os.chmod(tmp, mode)  # mkstemp makes it 0600; an output file gets the usual permissions
        os.replace(tmp, p)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(f"{flag} {p}: cannot write ({exc.strerror or exc})") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_atomic(path: Path | str, data: str | bytes, flag: str = "output") -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` atomically (temporary file, fsync, rename); returns the path."""
    p = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    with atomic_path(p, flag) as tmp, open(tmp, "wb") as fh:
        fh.write(raw)
        fh.flush()
        os.fsync(fh.fileno())
    return p


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_mission_outputs(
    result: Any,
    blueprint: Any,
    name: str,
    *,
    fmt: str,
    report: Path | None,
    gantt: Path | None,
    plot3d: Path | None,
    extra: Mapping[str, Any] | None = None,
) -> None:
    """A simulated mission's outputs, the same from ``masonry sim`` and ``masonry replay``: ``--report``,
    ``--gantt``, ``--plot3d`` (titled with ``name``), then the summary or the JSON on stdout.

    ``extra``: more keys of the JSON report (``mission-control``'s ``security``).
    """
    import json

    import typer

    out = result.to_dict() if not extra else {**result.to_dict(), **extra}
    if report is not None:
        write_atomic(report, json.dumps(out, indent=1) + "\n", "--report")
        typer.echo(f"wrote {report}", err=True)
    if gantt is not None:
        from masonry.viz.gantt import draw_gantt

        with atomic_path(gantt, "--gantt") as tmp:
            draw_gantt(result, tmp, title=f"{name}: {result.policy}, seed {result.seed}")
        typer.echo(f"wrote {gantt}", err=True)
    if plot3d is not None:
        from masonry.viz.plot3d import draw_plot3d

        with atomic_path(plot3d, "--plot3d") as tmp:
            draw_plot3d(blueprint, result, tmp, title=f"{name}: wall and flown paths")
        typer.echo(f"wrote {plot3d}", err=True)
    typer.echo(json.dumps(out) if fmt == "json" else result.summary())


__all__ = ["atomic_path", "check_output_path", "check_output_paths", "write_atomic", "write_mission_outputs"]
