"""The .sgt script language: grammar, parser, diagnostics, speech timing and the compiler.

Public API::

    from dsl import analyse, compile_file, compile_text, load_script
    script = analyse(text, "my.sgt")            # parse + static checks, no speech (fast)
    result = compile_file("my.sgt")             # + speech timing + control arrays
    result = compile_text(text)                 # the same from a string, no file
    result.diagnostics, result.plan

Importing this package is cheap: the analyser reads every body with a regular-expression
scanner (Lark and the grammar, dsl/sgt.lark, are the reference it is tested against), and the
speech engine loads when a voice is first checked or spoken.
"""

from __future__ import annotations

from pathlib import Path

from core.diagnostics import Diagnostic
from dsl.compiler import CompileResult, compile_file, compile_text, load_script
from dsl.parser import analyse

__all__ = ["analyse", "compile_file", "compile_text", "example_path", "load_script", "CompileResult", "Diagnostic"]

#: The example scripts shipped with sgt (``examples/`` of the checkout it is installed from).
EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def example_path(name: str) -> Path:
    """The shipped example script ``name`` (``"mall_guide"``, ``"lecture"``,
    ``"game_dialogue"``), wherever the current folder is; ``FileNotFoundError`` names the
    examples there are."""
    path = EXAMPLES / f"{name.removesuffix('.sgt')}.sgt"
    if not path.is_file():
        there = ", ".join(sorted(p.stem for p in EXAMPLES.glob("*.sgt"))) or "none"
        raise FileNotFoundError(f"no example '{name}' in {EXAMPLES} (there are: {there})")
    return path
