"""No dead code: vulture (settings in pyproject.toml's [tool.vulture], false positives in
vulture_whitelist.py) finds nothing, and every whitelist entry still names something."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytest.importorskip("vulture")


def _vulture(*extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vulture", *extra], cwd=ROOT, capture_output=True, text=True)


def _config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["vulture"]


def test_vulture_finds_no_dead_code():
    result = _vulture()
    assert result.returncode == 0 and result.stdout == "", (
        "vulture found dead code: delete it, or (a false positive) add it to vulture_whitelist.py "
        "with its reason:\n" + result.stdout + result.stderr)


def test_the_check_fails_on_new_dead_code(tmp_path):
    dead = tmp_path / "dead.py"
    dead.write_text("def never_called():\n    return 1\n\n\nUNUSED_SETTING = 3\n")
    cfg = _config()
    args = [*cfg["paths"], str(dead), "--min-confidence", str(cfg["min_confidence"]),
            "--ignore-names", ",".join(cfg["ignore_names"]), "--ignore-decorators", ",".join(cfg["ignore_decorators"])]
    result = _vulture(*args)
    assert result.returncode != 0
    assert "never_called" in result.stdout and "UNUSED_SETTING" in result.stdout


def test_every_whitelist_entry_is_still_defined():
    tree = ast.parse((ROOT / "vulture_whitelist.py").read_text())
    names = [n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name) and n.value.id == "_"]
    assert names
    code = "\n".join(p.read_text(encoding="utf-8") for d in _config()["paths"] if (ROOT / d).is_dir()
                     for p in sorted((ROOT / d).rglob("*.py")))
    stale = [n for n in names if not re.search(rf"(def |\.|\b){re.escape(n)}\s*(\(|=|:)", code)]
    assert stale == [], f"vulture_whitelist.py names what no longer exists: {stale}; remove them"


def test_scripts_and_benchmarks_import_names_that_exist():
    """Removing or renaming code must not break the scripts and benchmarks (no test runs them)."""
    import importlib
    import importlib.util

    missing = []
    for path in sorted((ROOT / "scripts").glob("*.py")) + sorted((ROOT / "benchmarks").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.module
                    and node.module.split(".")[0] in ("core", "library", "dsl", "model", "renders", "sgt_tui")):
                continue
            module = importlib.import_module(node.module)
            for alias in node.names:
                if not hasattr(module, alias.name) and importlib.util.find_spec(f"{node.module}.{alias.name}") is None:
                    missing.append(f"{path.name}: from {node.module} import {alias.name}")
    assert missing == []
