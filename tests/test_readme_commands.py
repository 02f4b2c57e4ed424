"""The README's command blocks run as written, in order, from a fresh checkout's root, and none
of them destroys a file (issue 22: `sgt export take.json -o take.json --rig nao` replaced the
take, and some lines named files no earlier line made).

Each `sgt ...` line of the blocks under "Quick start" and "Rendering and export" runs in a
fresh folder holding a copy of `examples/` (what a new checkout's root has), except `sgt edit`
(interactive: tests/test_editor_tmux.py runs it in a terminal). Every command must exit 0,
every output it names must exist afterwards, and the examples must be unchanged.
"""

from __future__ import annotations

import hashlib
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SECTIONS = ("## Quick start", "## Rendering and export")


def readme_commands() -> list[str]:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    lines = []
    for title in SECTIONS:
        section = readme.split(title, 1)[1].split("\n## ", 1)[0]
        for block in re.findall(r"```sh\n(.*?)```", section, re.S):
            for line in block.splitlines():
                command = line.split(" #", 1)[0].strip()
                if command.startswith("sgt ") and not command.startswith("sgt edit"):
                    lines.append(command)
    return lines


def _outputs(argv: list[str]) -> list[str]:
    out = []
    for flag in ("-o", "--sheet", "--mix"):
        if flag in argv:
            out.append(argv[argv.index(flag) + 1])
    return out


def _digest(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.skipif(shutil.which("bash") is None, reason="runs the lines as a shell would")
@pytest.mark.slow
def test_the_readme_command_blocks_run_in_order_from_a_fresh_folder(tmp_path):
    commands = readme_commands()
    assert len(commands) >= 25 and any(c.startswith("sgt export") for c in commands)
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    before = _digest(tmp_path / "examples")
    for command in commands:
        argv = shlex.split(command)
        # as a shell runs it (globs), with the sgt of this interpreter's environment
        env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
        r = subprocess.run(["bash", "-c", command], cwd=tmp_path, capture_output=True, text=True, timeout=600,
                           check=False, env=env)
        assert r.returncode == 0, f"{command}\n{r.stderr[-2000:]}"
        for out in _outputs(argv):
            path = tmp_path / out  # several speakers: one file each, OUT.SPEAKER.EXT
            assert path.exists() or list(tmp_path.glob(f"{path.stem}.*{path.suffix}")), f"{command}: no {out}"
    assert _digest(tmp_path / "examples") == before  # no example changed
    assert (tmp_path / "take.json").read_text(encoding="utf-8").lstrip().startswith("{")  # the take survives its exports
    assert "sgt-motion" in (tmp_path / "take.json").read_text(encoding="utf-8")[:200]


def test_the_readme_names_no_file_before_a_line_makes_it():
    """Every motion file a command reads was written by an earlier line (or is an example)."""
    made = set()
    for command in readme_commands():
        argv = shlex.split(command)
        reads = [a for a in argv[2:3] if a.endswith((".json", ".npz"))] + \
                ([argv[argv.index("--compare") + 1]] if "--compare" in argv else [])
        for name in reads:
            assert name in made, f"{command}: reads {name}, which no earlier line writes"
        made.update(_outputs(argv))
