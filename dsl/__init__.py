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

from core.diagnostics import Diagnostic
from dsl.compiler import CompileResult, compile_file, compile_text, load_script
from dsl.parser import analyse

__all__ = ["analyse", "compile_file", "compile_text", "load_script", "CompileResult", "Diagnostic"]
