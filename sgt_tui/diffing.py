"""``sgt diff``'s inputs (files, folders, git revisions, git's external-diff arguments), its
text output and its before/after renders. What changed is :mod:`dsl.diff`'s."""

from __future__ import annotations

import json
import os
import subprocess
from dataclasses import dataclass
from pathlib import Path

from core.counting import plural
from core.fileio import make_folder
from core.printable import UNSAFE, escaped
from core.reading import read_bytes
from sgt_tui.errors import InputError
from sgt_tui.progress import ProgressBar

SUFFIX = ".sgt"


class DiffInputError(Exception):
    """A version that cannot be read (``usage``: the arguments are wrong), one line for users."""

    def __init__(self, message: str, usage: bool = False) -> None:
        super().__init__(message)
        self.usage = usage


@dataclass
class Pair:
    """Two versions of one script: their texts (None: no such file on that side), the names
    shown for them, and where their relative paths resolve."""

    old_text: str | None
    new_text: str | None
    old_name: str
    new_name: str
    old_path: Path
    new_path: Path


def pairs_for(head: list[str], paths: list[str] | None = None) -> list[Pair]:
    """The script versions ``sgt diff HEAD... -- PATHS...`` compares (see its --help): ``head``
    the arguments before ``--``, ``paths`` those after it (None: there was no ``--``). As in
    ``git diff``, everything after ``--`` is a path; one that exists in neither version is an
    error, which says that options go before ``--``."""
    if paths is None:
        if len(head) == 7 and _looks_like_git_external(head):
            return [_external(head)]
        if len(head) == 2 and all(os.path.exists(a) for a in head):
            a, b = map(Path, head)
            if a.is_dir() and b.is_dir():
                return _folders(a, b)
            if a.is_dir() or b.is_dir():
                raise DiffInputError(f"compare two files or two folders, not a file and a folder "
                                     f"({quoted(head[0])}, {quoted(head[1])})", usage=True)
            return [Pair(_read(a), _read(b), str(a), str(b), a, b)]
    if not head:
        raise DiffInputError("give two scripts, or a git revision (sgt diff HEAD~1 FILE, sgt diff A..B -- PATHS)", usage=True)
    rev = head[0]
    git = Git.here()
    if git is None:
        missing = [a for a in head if not os.path.exists(a)]
        raise DiffInputError(f"{quoted(missing[0] if missing else head[0])}: no such file, and not in a git repository "
                             f"(for a revision)", usage=True)
    if ".." in rev:
        old_rev, new_rev = git.range(rev)
    elif git.is_revision(rev):
        old_rev, new_rev = rev, None
    else:
        raise DiffInputError(f"{quoted(rev)}: no such file, and not a git revision", usage=True)
    for path in head[1:]:
        git.check_path(path, old_rev, new_rev, after_dashes=False)
    for path in paths or ():
        git.check_path(path, old_rev, new_rev, after_dashes=True)
    return git.changed(old_rev, new_rev, head[1:] + (paths or []))


def _read(path: Path) -> str:
    """A script's text by the rules every command reads scripts by (regular files only, the
    size limit); undecodable bytes are shown replaced (a diff is only read)."""
    try:
        data = read_bytes(path, "script")
    except OSError as exc:
        raise DiffInputError(f"{quoted(str(path))}: {getattr(exc, 'reason', None) or exc.strerror or exc}") from None
    return data.decode("utf-8-sig", "replace")


def _folders(a: Path, b: Path) -> list[Pair]:
    old = {p.relative_to(a).as_posix() for p in a.rglob(f"*{SUFFIX}") if p.is_file()}
    new = {p.relative_to(b).as_posix() for p in b.rglob(f"*{SUFFIX}") if p.is_file()}
    return [Pair(_read(a / r) if r in old else None, _read(b / r) if r in new else None, str(a / r), str(b / r),
                 a / r, b / r) for r in sorted(old | new)]


def _looks_like_git_external(args: list[str]) -> bool:
    """git's external diff: path old-file old-hex old-mode new-file new-hex new-mode."""
    hexes = (args[2], args[5])
    return all(len(h) >= 7 and all(c in "0123456789abcdef" for c in h) for h in hexes)


def _external(args: list[str]) -> Pair:
    path, old_file, new_file = args[0], args[1], args[4]
    old = None if old_file == os.devnull else _read(Path(old_file))
    new = None if new_file == os.devnull else _read(Path(new_file))
    return Pair(old, new, f"a/{path}", f"b/{path}", Path(path), Path(path))


class Git:
    """The git repository around the current folder, run as a subprocess."""

    def __init__(self, top: Path) -> None:
        self.top = top

    @classmethod
    def here(cls) -> Git | None:
        r = _git(["rev-parse", "--show-toplevel"], Path.cwd())
        return cls(Path(r.stdout.strip())) if r is not None and r.returncode == 0 else None

    def is_revision(self, rev: str) -> bool:
        r = _git(["rev-parse", "--verify", "--quiet", f"{rev}^{{commit}}"], self.top)
        return r is not None and r.returncode == 0

    def range(self, spec: str) -> tuple[str, str]:
        """The (old, new) revisions of ``A..B`` (``A...B``: from their merge base); empty ends are HEAD."""
        three = "..." in spec
        a, b = spec.split("...", 1) if three else spec.split("..", 1)
        a, b = a or "HEAD", b or "HEAD"
        for rev in (a, b):
            if not self.is_revision(rev):
                raise DiffInputError(f"{rev}: not a git revision (in {spec})", usage=True)
        if three:
            r = _git(["merge-base", a, b], self.top)
            if r is None or r.returncode != 0:
                raise DiffInputError(f"{spec}: {a} and {b} have no common ancestor")
            a = r.stdout.strip()
        return a, b

    def check_path(self, path: str, old: str, new: str | None, *, after_dashes: bool) -> None:
        """Refuse a path that is in neither version (``new`` None: the working tree), as one
        line that names it; after ``--`` it may be an option put in the wrong place. A
        pathspec git expands (``*.sgt``, ``:(glob)...``) and a path outside the repository are
        left to git."""
        rel = os.path.relpath(os.path.abspath(path), self.top)
        if any(c in path for c in "*?[") or path.startswith(":") or rel == ".." or rel.startswith(".." + os.sep):
            return
        if (new is None and os.path.lexists(path)) or self.exists(old, rel) or (new is not None and self.exists(new, rel)):
            return
        where = f"{old} or {new}" if new is not None else f"{old} or the working tree"
        hint = ("; everything after '--' is a path: put options before '--' (sgt diff --format json A..B -- PATHS)"
                if after_dashes else "")
        raise DiffInputError(f"{quoted(path)}: no such file or folder in {where}{hint}", usage=True)

    def exists(self, rev: str, rel: str) -> bool:
        """Whether ``rel`` (a file or a folder, from the top) is in revision ``rev``."""
        if rel == ".":
            return True
        r = _git(["cat-file", "-e", f"{rev}:{Path(rel).as_posix()}"], self.top)
        return r is not None and r.returncode == 0

    def changed(self, old: str, new: str | None, paths: list[str]) -> list[Pair]:
        """Every .sgt file that differs between ``old`` and ``new`` (None: the working tree)
        under ``paths`` (all when empty), renames followed."""
        where = [os.path.relpath(os.path.abspath(p), self.top) for p in paths]
        r = _git(["diff", "--name-status", "-M", "-z", old, *([new] if new else []), "--", *(where or ["."])], self.top)
        if r is None or r.returncode != 0:
            raise DiffInputError(f"git diff failed: {escaped(r.stderr.strip()) if r else 'git not found'}")
        fields = r.stdout.split("\0")
        out = []
        i = 0
        while i < len(fields) and fields[i]:
            status = fields[i]
            if status[0] in "RC":
                a, b = fields[i + 1], fields[i + 2]
                i += 3
            else:
                a = b = fields[i + 1]
                i += 2
            if not (a.endswith(SUFFIX) or b.endswith(SUFFIX)):
                continue
            old_text = None if status[0] == "A" else self.show(old, a)
            if status[0] == "D":
                new_text = None
            elif new is None:
                new_text = _read(self.top / b)
            else:
                new_text = self.show(new, b)
            out.append(Pair(old_text, new_text, f"{old}:{a}", f"{new}:{b}" if new else b, self.top / a, self.top / b))
        if paths and not out:
            for p in paths:  # a file named explicitly that did not change is still compared (all "same")
                if os.path.isfile(p) and p.endswith(SUFFIX):
                    rel = os.path.relpath(os.path.abspath(p), self.top)
                    text = _read(Path(p))
                    out.append(Pair(self.show(old, rel), text if new is None else self.show(new, rel), f"{old}:{rel}",
                                    p if new is None else f"{new}:{rel}", Path(p), Path(p)))
        return out

    def show(self, rev: str, rel: str) -> str | None:
        r = _git(["show", f"{rev}:{rel}"], self.top, text=False)
        if r is None or r.returncode != 0:
            return None
        return r.stdout.decode("utf-8", "replace")


def _git(args: list[str], cwd: Path, text: bool = True):
    try:
        return subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=text, check=False, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None


# -- text --------------------------------------------------------------------------------------

def quoted(name: str) -> str:
    """A file name as git shows one: as it is, or, when it holds a character of :data:`UNSAFE`,
    in double quotes with those escaped (and ``\\`` and ``"`` too, so that the escapes are
    unambiguous)."""
    if not UNSAFE.search(name):
        return name
    return '"' + escaped(name.replace("\\", "\\\\").replace('"', '\\"')) + '"'


def json_diff(doc) -> str:
    """``doc`` as ``sgt diff --format json`` prints it: JSON whose strings escape every character
    of :data:`UNSAFE` (json escapes the C0 controls itself; those left in the text are its
    own line breaks)."""
    text = json.dumps(doc, indent=1, ensure_ascii=False)
    return UNSAFE.sub(lambda m: m.group() if m.group() < "\x7f" else f"\\u{ord(m.group()):04x}", text)


_MARK = {"changed": "~", "moved": ">", "added": "+", "removed": "-", "affected": ".", "same": "="}
_COLOR = {"changed": "33", "moved": "36", "added": "32", "removed": "31", "affected": "2", "same": "2"}
#: The mark and colour of what is said once for many utterances (a header change, a shift).
_SHARED = ("*", "35")


def format_diff(d, *, color: bool = False, include_same: bool = False) -> str:
    """The text of one script's diff: a header; the header changes, once each; then each
    utterance that changed with a line per change of its own, and each shift of the starts
    once, where it begins. ``affected`` utterances (only a header change or a shift applies)
    are listed with ``include_same`` alone. Marks (``~ > + - *``) say the status without colour.
    Names and text from the files are :func:`quoted` and :func:`escaped`: nothing in a file
    reaches the terminal raw."""

    def paint(code: str, text: str) -> str:
        return f"\x1b[{code}m{text}\x1b[0m" if color else text

    c = d.counts()
    summary = ", ".join(f"{c[k]} {k}" for k in ("changed", "moved", "added", "removed", "affected") if c[k]) or "no changes"
    lines = [paint("1", f"{quoted(d.old_name)} -> {quoted(d.new_name)}") + f"  ({summary}; {c['same']} unchanged)"]
    lines += [paint("33", f"  note: {escaped(p)}") for p in d.problems]
    lines += [paint(_SHARED[1], f"{_SHARED[0]} {escaped(describe_header(h))}") for h in d.header]
    shown = None
    for u in d.utterances:
        if u.shift is not None and u.shift != shown:
            shown = u.shift
            lines.append(paint(_SHARED[1], f"{_SHARED[0]} {describe_shift(d.shifts[u.shift])}"))
        if not include_same and u.status in ("same", "affected"):
            continue
        side = u.new or u.old
        who = f"{escaped(side.speaker)}: " if side.speaker else ""
        lines.append(paint(_COLOR[u.status], f"{_MARK[u.status]} {_where(u)}  {who}\"{escaped(_short(side.text))}\""))
        for ch in u.changes:
            lines.append("    " + escaped(describe(ch)))
    return "\n".join(lines) + "\n\n"


def describe_header(h) -> str:
    """A header change in words: ``@rate visitor: 160 -> 190 (8 lines, each 0.47 s shorter)``."""
    if h.kind != "voice":
        (name, old, new), = h.settings
        if h.kind == "gap":
            return f"{name}: {old:g} s -> {new:g} s (the silence between lines)"
        return f"{name}: {old} -> {new} (every line's motion is drawn anew)"
    who = ", ".join("(lines without a speaker)" if s is None else s for s in h.speakers)
    said = "; ".join(f"{name} {who}: {old} -> {new}" for name, old, new in h.settings)
    n = len(h.lines)
    lengths = [new - old for _, old, new in h.lengths]
    return f"{said} ({plural(n, 'line')}{_lengths(lengths, len(h.lengths) == n)})"


def _lengths(deltas: list[float], all_of_them: bool) -> str:
    if not deltas:
        return ""
    lo, hi = min(deltas), max(deltas)
    if hi - lo < 0.005:
        each = "each " if all_of_them and len(deltas) > 1 else ""
        return f", {each}{abs(lo):.2f} s {'longer' if lo > 0 else 'shorter'}" if abs(lo) >= 0.005 else ""
    if lo > 0 or hi < 0:
        return f", {min(abs(lo), abs(hi)):.2f} to {max(abs(lo), abs(hi)):.2f} s {'longer' if lo > 0 else 'shorter'}"
    return f", lengths {lo:+.2f} to {hi:+.2f} s"


def describe_shift(shift) -> str:
    """A run of starts that moved in words: ``from line 7 on, every line starts 2.20 s earlier``."""
    first, last = shift.lines[0], shift.lines[-1]
    if len(shift.starts) == 1:
        ((_, old, new),) = shift.starts
        return f"line {first} starts {abs(new - old):.2f} s {'later' if new > old else 'earlier'} ({old:.2f} -> {new:.2f} s)"
    which = f"from line {first} on, every line starts" if shift.to_end else f"lines {first} to {last} start"
    lo, hi = min(shift.seconds), max(shift.seconds)
    if shift.constant:
        return f"{which} {abs(shift.seconds[0]):.2f} s {'later' if shift.seconds[0] > 0 else 'earlier'}"
    if lo > 0 or hi < 0:
        return (f"{which} {'later' if lo > 0 else 'earlier'}, by {min(abs(lo), abs(hi)):.2f} "
                f"to {max(abs(lo), abs(hi)):.2f} s")
    return f"{which} at another time, {lo:+.2f} to {hi:+.2f} s"


def _where(u) -> str:
    if u.old is not None and u.new is not None and u.old.line != u.new.line:
        return f"line {u.old.line} -> {u.new.line}"
    side = u.new or u.old
    return f"line {side.line}"


def _short(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"


def describe(ch) -> str:
    """One change in words."""
    k, what, old, new = ch.kind, ch.what, ch.old, ch.new
    if k == "text":
        return f"text: \"{_short(str(old))}\" -> \"{_short(str(new))}\""
    if k in ("speaker", "voice", "gap"):
        return f"{what}: {old} -> {new}"
    if k.endswith("-added"):
        return f"{k.split('-')[0]} {what} added on \"{new}\""
    if k.endswith("-removed"):
        return f"{k.split('-')[0]} {what} removed (was on \"{old}\")" if k != "pause-removed" else f"pause removed ({old})"
    if k.endswith("-moved"):
        return f"{k.split('-')[0]} {what} moved from \"{old}\" to \"{new}\""
    if k in ("pose-options", "style-values"):
        return f"{k.split('-')[0]} {what}: {old} -> {new}"
    if k == "pause-length":
        return f"pause: {old:g}s -> {new:g}s"
    if k == "retimed":
        delta = new - old
        return f"starts {abs(delta):.2f} s {'later' if delta > 0 else 'earlier'} ({old:.2f} -> {new:.2f} s)"
    if k == "length":
        return f"length: {old:.2f} -> {new:.2f} s"
    return f"{k} {what}: {old} -> {new}"


# -- renders -------------------------------------------------------------------------------------


def render_changes(pairs: list[Pair], diffs, folder: Path, *, engine: str | None, size, video: bool) -> list[Path]:
    """For each utterance both versions have and that changed (more than its start time; a
    header change of its voice counts), the
    old take beside the new one (A old, B new) in ``folder``: ``STEM_lineNNNN.gif`` (or
    ``.mp4``, without sound: two speeches cannot play as one) named by the new version's line.
    Returns the files written."""
    from model.generate import GenerateError, generate  # lazy: numpy, the engines
    from renders.animate import render_gif, render_mp4  # lazy: PIL, GL
    from renders.mannequin import Mannequin  # lazy: GL

    make_folder(folder)
    # an utterance that only plays at another time moves the same way: nothing to compare
    jobs = [(p, u) for p, d in zip(pairs, diffs) for u in d.utterances if u.old is not None and u.new is not None
            and (u.header or any(c.kind != "retimed" for c in u.changes))]
    written: list[Path] = []
    m = Mannequin(*size)
    try:
        for k, (p, u) in enumerate(jobs):
            try:
                old = generate(p.old_path, source=p.old_text, engine=engine, utterances=[u.old.index]).clips[0]
                new = generate(p.new_path, source=p.new_text, engine=engine, utterances=[u.new.index]).clips[0]
            except GenerateError as exc:
                raise InputError(f"{quoted(p.new_name)}: cannot render line {u.new.line}: {escaped(str(exc))}") from None
            out = folder / f"{Path(p.new_path).stem}_line{u.new.line:04d}.{'mp4' if video else 'gif'}"
            labels = ("A old", "B new")
            bar = ProgressBar(f"render {k + 1}/{len(jobs)}")
            if video:
                render_mp4([old, new], out, labels=labels, size=size, mannequin=m, progress=bar)
            else:
                render_gif(old, out, compare=new, labels=labels, size=size, mannequin=m, progress=bar)
            written.append(out)
    finally:
        m.close()
    return written
