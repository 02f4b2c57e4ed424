"""The architecture holds: layer contracts (import-linter) and no hidden import cycles.

Layers (DEVELOPERS.md): core < library < dsl < model (engines) < model.training < renders < sgt_tui.
A project import inside a function is allowed only where it defers a heavy library, with a
``# lazy: <library>`` comment on the line, or in a command module (``sgt_tui/commands``), whose
``run`` imports what it needs so that building the parser (``sgt --help``) stays cheap.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("core", "library", "dsl", "model", "renders", "sgt_tui")


def _function_level_project_imports(path: Path) -> list[tuple[int, str]]:
    source = path.read_text(encoding="utf-8")
    lines = source.splitlines()
    found = {}
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for sub in ast.walk(node):
            if isinstance(sub, ast.ImportFrom):
                module = path.parent.name if sub.level else (sub.module or "")
            elif isinstance(sub, ast.Import):
                module = sub.names[0].name
            else:
                continue
            if module.split(".")[0] in PACKAGES and "# lazy:" not in lines[sub.lineno - 1]:
                found[sub.lineno] = module
    return sorted(found.items())


def test_project_imports_inside_functions_only_defer_heavy_libraries():
    offenders = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.parent.name == "commands" or path.name == "cli.py":
                continue
            offenders += [f"{path.relative_to(ROOT)}:{line} imports {module}"
                          for line, module in _function_level_project_imports(path)]
    assert not offenders, "import at module level, or say what it defers with '# lazy: <library>':\n" + "\n".join(offenders)


def test_the_checker_sees_a_function_level_import(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("def f():\n    from dsl.parser import analyse\n    import model.net  # lazy: torch\n")
    assert _function_level_project_imports(f) == [(2, "dsl.parser")]


@pytest.mark.skipif(shutil.which("lint-imports") is None, reason="import-linter is a dev dependency")
def test_layer_contracts_hold():
    r = subprocess.run(["lint-imports"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    assert "0 broken" in r.stdout


def test_core_imports_nothing_heavy():
    code = ("import sys, core.skeleton, core.controls, core.words, core.motion, core.fileio, core.diagnostics; "
            "print(sorted(m for m in ('torch', 'lark', 'textual', 'scipy', 'librosa', 'OpenGL', 'PIL') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
