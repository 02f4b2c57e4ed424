"""The .sgt script language: grammar, parser, diagnostics, speech timing and the compiler.

Public API::

    from dsl import analyse, compile_file, load_script
    script = analyse(text, "my.sgt")            # parse + static checks, no speech (fast)
    result = compile_file("my.sgt")             # + speech timing + control arrays
    result.diagnostics, result.plan

Importing this package is cheap: Lark, numpy-heavy work and the speech engine load on use.
"""

from __future__ import annotations

__all__ = ["analyse", "compile_file", "load_script", "CompileResult", "Diagnostic"]


def __getattr__(name):
    if name == "analyse":
        from dsl.parser import analyse

        return analyse
    if name in ("compile_file", "load_script", "CompileResult"):
        from dsl import compiler

        return getattr(compiler, name)
    if name == "Diagnostic":
        from core.diagnostics import Diagnostic

        return Diagnostic
    raise AttributeError(name)
