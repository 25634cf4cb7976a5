"""The code's health figures that CI prints and ratchets: module sizes, ``Any`` and in-function imports.

Issue 28 asks for no module in ``src/`` over 600 lines, ``Any`` only at the true boundaries and no hidden import
cycles. The figures are counted here, once, for both ``.ci/run`` (which prints them: ``python
tests/code_health.py``) and ``tests/test_code_health.py`` (which fails when one rises above its ceiling). The
ceilings in :data:`CEILINGS` and :data:`OVERSIZE_CEILINGS` only ever go down: lower them when a change lowers a
figure, never raise them.
"""

from __future__ import annotations

import ast
import re
import sys
from dataclasses import dataclass
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src" / "masonry"
MAX_MODULE_LINES = 600
#: Issue 27 §4's simplicity target: no module under ``mission/`` over this many lines.
MISSION_MAX_LINES = 500
#: Issue 27 §4's target for mission control's shell (``mission/control.py``); it regrew past it once (396 -> 427).
CONTROL_MAX_LINES = 400
#: The airspace's protocol (``mission/airspace.py``): 499 lines before its records and its flights' progress moved
#: out (``airspace_records``, ``airspace_progress``), 245 after; this keeps it from regrowing into the biggest.
AIRSPACE_MAX_LINES = 300
#: The UAV side's handler (``mission/handler.py``): 491 lines before its battery reserve and its assignment check
#: moved out (``handler_battery``, ``handler_check``), 382 after.
HANDLER_MAX_LINES = 400

# Issue 28 counted 674 mentions of Any and 158 in-function imports when it was filed; the ceilings are today's.
CEILINGS = {"any_mentions": 538, "in_function_imports": 149}

# The modules still over MAX_MODULE_LINES, each at most the size it had when the ratchet began: a module here may
# only shrink, and one that drops to MAX_MODULE_LINES or below leaves the list (the test says so).
OVERSIZE_CEILINGS: dict[str, int] = {}

_ANY = re.compile(r"\bAny\b")


@dataclass(frozen=True)
class Health:
    """The counted figures of one source tree."""

    module_lines: dict[str, int]
    any_mentions: int
    in_function_imports: int


def _is_own(node: ast.AST) -> int:
    """How many of masonry's own modules an import statement imports (absolute or relative)."""
    if isinstance(node, ast.ImportFrom):
        return int(node.level > 0 or (node.module or "").split(".")[0] == "masonry")
    if isinstance(node, ast.Import):
        return sum(alias.name.split(".")[0] == "masonry" for alias in node.names)
    return 0


def _in_function_imports(node: ast.AST, in_function: bool = False) -> int:
    """Imports of masonry's own modules that stand inside a function body (each counted once)."""
    count = _is_own(node) if in_function else 0
    inside = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
    return count + sum(_in_function_imports(child, inside) for child in ast.iter_child_nodes(node))


def measure(src: Path = SRC) -> Health:
    """Count the figures over every ``.py`` file under ``src``."""
    lines: dict[str, int] = {}
    any_mentions = 0
    imports = 0
    for path in sorted(src.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        lines[path.relative_to(src).as_posix()] = len(text.splitlines())
        any_mentions += len(_ANY.findall(text))
        imports += _in_function_imports(ast.parse(text, filename=str(path)))
    return Health(lines, any_mentions, imports)


def main() -> int:
    """Print the figures against their ceilings (CI's log shows them on every run)."""
    health = measure()
    over = {name: n for name, n in health.module_lines.items() if n > MAX_MODULE_LINES}
    print(
        f"code health: {len(over)} modules over {MAX_MODULE_LINES} lines, "
        f"Any mentioned {health.any_mentions} times (ceiling {CEILINGS['any_mentions']}), "
        f"{health.in_function_imports} in-function imports of masonry (ceiling {CEILINGS['in_function_imports']})"
    )
    for name, n in sorted(over.items(), key=lambda item: -item[1]):
        print(f"  {n:5d}  src/masonry/{name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
