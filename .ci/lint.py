"""Structure checks of the code base; exit status 1 when one fails.

Checks the shipped packages (``radcons``, ``inspector``, ``demo_data_gen``):

- no file over 500 lines and no function over 100 lines;
- every stage of :data:`radcons.stages.STAGE_LIST` has its package under
  ``radcons/stages/`` with ``params.py`` and ``step.py``, and no stage module lies loose
  beside the packages;
- imports go down: a stage package imports no other stage's package, the shared numerics
  import no stage, and the library reaches the inspector and the demo generator only from
  its command line;
- README.md has at most 200 lines.

Run it as ``./dev lint``.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("radcons", "inspector", "demo_data_gen")
MAX_FILE_LINES = 500
MAX_FUNCTION_LINES = 100
MAX_README_LINES = 200


def python_files() -> list[Path]:
    """Every module of the shipped packages."""
    return sorted(path for package in PACKAGES for path in (ROOT / package).rglob("*.py"))


def long_files(paths: list[Path]) -> list[str]:
    """Files over :data:`MAX_FILE_LINES` lines."""
    out = []
    for path in paths:
        count = path.read_text(encoding="utf-8").count("\n")
        if count > MAX_FILE_LINES:
            out.append(f"{path.relative_to(ROOT)} ({count})")
    return out


def long_functions(paths: list[Path]) -> list[str]:
    """Functions and methods over :data:`MAX_FUNCTION_LINES` lines."""
    out = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    out.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({length})")
    return out


def stages_without_package() -> list[str]:
    """Stages whose package lacks ``params.py`` or ``step.py``, and loose stage modules."""
    sys.path.insert(0, str(ROOT))
    from radcons.stages import STAGE_LIST

    stages_dir = ROOT / "radcons" / "stages"
    out = [
        stage.name
        for stage in STAGE_LIST
        if not all((stages_dir / stage.package / name).is_file() for name in ("__init__.py", "params.py", "step.py"))
    ]
    out += [f"{path.name} (loose module)" for path in stages_dir.glob("*.py") if path.name != "__init__.py"]
    return out


def _imports(path: Path) -> list[str]:
    names = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.append(node.module)
        elif isinstance(node, ast.Import):
            names.extend(alias.name for alias in node.names)
    return names


def upward_imports(paths: list[Path]) -> list[str]:
    """Imports that point the wrong way (see the module docstring)."""
    out = []
    for path in paths:
        parts = path.relative_to(ROOT).with_suffix("").parts
        for module in _imports(path):
            target = module.split(".")
            if parts[0] == "radcons" and target[0] in ("inspector", "demo_data_gen") and parts[:2] != ("radcons", "cli"):
                out.append(f"{path.relative_to(ROOT)} imports {module}")
            if parts[:2] == ("radcons", "numerics") and target[:2] == ["radcons", "stages"]:
                out.append(f"{path.relative_to(ROOT)} imports {module}")
            if len(parts) > 3 and parts[:2] == ("radcons", "stages") and target[:2] == ["radcons", "stages"]:
                if len(target) > 2 and target[2] != parts[2]:
                    out.append(f"{path.relative_to(ROOT)} imports {module}")
    return out


def readme_lines() -> int:
    """Lines of README.md."""
    return (ROOT / "README.md").read_text(encoding="utf-8").count("\n")


def main() -> int:
    """Print one line per check; return 1 when any fails."""
    paths = python_files()
    checks = [
        (f"files over {MAX_FILE_LINES} lines", long_files(paths)),
        (f"functions over {MAX_FUNCTION_LINES} lines", long_functions(paths)),
        ("stages without a package", stages_without_package()),
        ("imports pointing up", upward_imports(paths)),
    ]
    failed = False
    for title, found in checks:
        print(f"{title}: {', '.join(found) if found else 'none'}")
        failed |= bool(found)
    lines = readme_lines()
    print(f"README: {lines} lines (at most {MAX_README_LINES})")
    failed |= lines > MAX_README_LINES
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
