"""The hostile audit of issue 21, finding by finding: each input it reported, as a test that
failed on the code it audited (742c655) and passes now.

Commands run as the user runs them (a subprocess where a crash would end the process, the
command's ``main`` in-process elsewhere); services in their own process on 127.0.0.1 only
(tests/test_serve_process.py).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def sgt(*args: str, cwd: Path, timeout: float = 120, stdin=None) -> subprocess.CompletedProcess:
    """``sgt ARGS`` in a process of its own (a crash or a hang ends only it)."""
    return subprocess.run([sys.executable, "-m", "sgt_tui.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, stdin=stdin if stdin is not None else subprocess.DEVNULL,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "SGT_CACHE_DIR": str(cwd / ".cache")})


# -- 1 and 2: a voice variant killed the process and read any file ---------------------------


@pytest.mark.parametrize("variant", ["a" * 40, "../../../../../../etc/passwd"])
@pytest.mark.parametrize("command", ["check", "compile", "generate"])
def test_a_hostile_voice_variant_is_a_diagnostic(tmp_path, variant, command):
    """`@voice en-us+aaaa...` (40 characters) aborted `sgt check` (exit 134, a buffer overflow
    inside espeak-ng); `@voice en-us+../../../../etc/passwd` passed and `sgt compile` printed
    the file line by line. Both are SGT211 now, before espeak-ng sees them."""
    (tmp_path / "s.sgt").write_text(f"@voice en-us+{variant}\nguide: hi there.\n")
    args = {"check": ["check", "s.sgt"], "compile": ["compile", "s.sgt", "-o", "plan.json"],
            "generate": ["generate", "s.sgt", "-o", "take.json"]}[command]
    r = sgt(*args, cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    out = r.stdout + r.stderr  # check prints its report on stdout, the others on stderr
    assert "SGT211" in out and "unknown voice variant" in out
    assert "root:" not in out and "Bad voice attribute" not in out
    assert "Traceback" not in r.stderr


def test_sgt_voices_lists_the_variants(tmp_path):
    r = sgt("voices", "--variants", cwd=tmp_path)
    assert r.returncode == 0
    names = [line.split()[0] for line in r.stdout.splitlines()[:-1]]
    assert "m3" in names and "f2" in names and "variants" in r.stdout.splitlines()[-1]
    (tmp_path / "ok.sgt").write_text(f"@voice en-gb+{names[0]}\nguide: hi there.\n")
    assert sgt("check", "ok.sgt", cwd=tmp_path).returncode == 0
