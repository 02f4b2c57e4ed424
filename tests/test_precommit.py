"""The pre-commit hooks (.pre-commit-hooks.yaml) run by the pre-commit package itself, on a
temporary git repository: a script with an error is rejected by sgt-check, an unformatted one
is rewritten by sgt-fmt (and so rejected once), and formatted clean scripts pass."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
pytest.importorskip("pre_commit")
pytestmark = pytest.mark.skipif(shutil.which("git") is None, reason="pre-commit needs git")


def _git(repo: Path, *args: str) -> str:
    env = {**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.org", "GIT_COMMITTER_NAME": "t",
           "GIT_COMMITTER_EMAIL": "t@example.org"}
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True, env=env).stdout


def _pre_commit(repo: Path, home: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PRE_COMMIT_HOME": str(home),
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}  # this environment's sgt
    return subprocess.run([sys.executable, "-m", "pre_commit", "run", "--all-files", "--color", "never"], check=False, cwd=repo,
                          capture_output=True, text=True, env=env, timeout=300)


def test_the_hooks_reject_a_bad_script_and_pass_a_formatted_one(tmp_path):
    hooks = tmp_path / "hooks"  # the hook repository: this project's hooks file, committed
    hooks.mkdir()
    shutil.copy(ROOT / ".pre-commit-hooks.yaml", hooks)
    _git(hooks, "init", "-q")
    _git(hooks, "add", ".")
    _git(hooks, "commit", "-q", "-m", "hooks")
    rev = _git(hooks, "rev-parse", "HEAD").strip()

    repo = tmp_path / "project"
    repo.mkdir()
    _git(repo, "init", "-q")
    (repo / ".pre-commit-config.yaml").write_text(
        f"repos:\n  - repo: {hooks}\n    rev: {rev}\n    hooks:\n      - id: sgt-check\n      - id: sgt-fmt\n")
    (repo / "good.sgt").write_text("@rate 160\n\nguide: [pose:wave] Hello there!\n")
    _git(repo, "add", ".")
    home = tmp_path / "pre-commit-home"

    r = _pre_commit(repo, home)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "sgt check" in r.stdout and "Passed" in r.stdout

    (repo / "bad.sgt").write_text("guide: [pose:wave_hello] Hello!\n")
    _git(repo, "add", ".")
    r = _pre_commit(repo, home)
    assert r.returncode == 1
    assert "SGT201" in r.stdout and "unknown gesture 'wave_hello'" in r.stdout

    (repo / "bad.sgt").write_text("guide :  [ pose:wave ]  Hello!\n")  # right, but not formatted
    _git(repo, "add", ".")
    r = _pre_commit(repo, home)
    assert r.returncode == 1 and "files were modified by this hook" in r.stdout
    assert (repo / "bad.sgt").read_text() == "guide: [pose:wave] Hello!\n"
    _git(repo, "add", ".")
    r = _pre_commit(repo, home)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_documented_configurations_name_the_hooks():
    import yaml

    hooks = {h["id"]: h for h in yaml.safe_load((ROOT / ".pre-commit-hooks.yaml").read_text())}
    assert set(hooks) == {"sgt-check", "sgt-fmt", "sgt-fmt-check"}
    doc = (ROOT / "docs" / "editors.md").read_text(encoding="utf-8").split("## pre-commit", 1)[1]
    remote, local = (yaml.safe_load(block.split("```", 1)[0]) for block in doc.split("```yaml\n")[1:3])
    assert [h["id"] for h in remote["repos"][0]["hooks"]] == ["sgt-check", "sgt-fmt"]
    for hook in local["repos"][0]["hooks"]:  # the local variant runs what the hooks run
        assert (hook["entry"], hook["language"], hook["files"]) == (hooks[hook["id"]]["entry"], "system", r"\.sgt$")
