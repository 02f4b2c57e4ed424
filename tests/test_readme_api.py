"""The README's Python API example runs as written, and says what it computes."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def readme_api_example() -> str:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("### Python API", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, re.S)
    assert match, "no python block under '### Python API' in README.md"
    return match.group(1)


def test_readme_python_api_example_runs(tmp_path, monkeypatch):
    """From a fresh folder, as a notebook elsewhere would run it (it used to read examples/
    relative to the current folder)."""
    code = readme_api_example()
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, "README.md (Python API)", "exec"), namespace)

    # what its comment promises: "(41, 27), (41, 10, 3)"
    shapes = re.search(r"clips\[1\]\.positions\.shape\s+#\s*(\(.*\))\s*$", code, re.M).group(1)
    clip = namespace["clips"][1]
    assert f"{tuple(clip.poses.shape)}, {tuple(clip.positions.shape)}" == shapes
    # the files it asked for, and nothing else
    assert sorted(p.name for p in tmp_path.iterdir()) == ["take.bvh", "take.gif"]
    assert (tmp_path / "take.gif").read_bytes().startswith(b"GIF89a")
    assert (tmp_path / "take.bvh").read_text().startswith("HIERARCHY")
    # from text: a plan, then motion from the plan and from the text, no file involved
    take = namespace["take"]
    assert namespace["result"].plan is not None and take.clips and take.clips[0].n_frames == take.plan.utterances[0].n_frames
    assert [w.word for w in take.plan.utterances[0].words[:2]] == ["Welcome", "to"]
    assert [c.name for c in take.plan.utterances[0].controls if c.kind == "pose"] == ["open_arms", "point_right"]


def test_example_path_names_the_shipped_examples():
    import pytest

    from dsl import example_path

    assert example_path("lecture") == example_path("lecture.sgt") == ROOT / "examples" / "lecture.sgt"
    with pytest.raises(FileNotFoundError, match="there are: game_dialogue, lecture, mall_guide"):
        example_path("nope")
