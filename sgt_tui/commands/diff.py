"""sgt diff: what changed between two versions of scripts, utterance by utterance."""

from __future__ import annotations

import argparse
import sys

HELP = "what changed between two versions of scripts: utterances, gestures, styles, timing"
DESCRIPTION = """\
Compare two versions of .sgt scripts and say, utterance by utterance, what the characters
will do differently: lines added, removed, moved or reworded; gestures added, removed,
moved to another word or played otherwise (x2, flip, hold=); style spans, pauses, voices,
@gap; and where each line plays on the performance clock. Utterances are matched by their
speaker and words, not by line number, so an inserted line does not make every later one
"changed". What many lines share is said once (marked *): a header change (a speaker's
@voice, @rate, @pitch; @gap, @seed) and a run of lines that all start later or earlier
because of an earlier change ("from line 7 on, every line starts 2.20 s earlier"); each line
then lists only what else changed in it.

  sgt diff OLD.sgt NEW.sgt            two files (or two folders: scripts matched by path)
  sgt diff HEAD~1 lobby.sgt           a file at a git revision against the working tree
  sgt diff main..feature -- scripts/  every script changed between two revisions (renames
                                      followed), limited to PATHS after --
  sgt diff HEAD                       every script changed since a revision

Options go before '--' (anywhere before it); everything after '--' is a path, as in git,
and a path in neither version is an error.

As git's external diff (GIT_EXTERNAL_DIFF, or diff.sgt.command with a .gitattributes line
'*.sgt diff=sgt') it takes git's seven arguments. Word times are estimated from the text
(no speech engine) unless --timing speech.

--render DIR writes, for each changed utterance that both versions have, a GIF (or MP4
with --video) of the old take and the new one side by side (A old, B new).

Exit status: 0 whether or not scripts differ (like 'git diff'; --exit-code: 1 when they
do), 1 for a file or revision that cannot be read, 2 for usage errors."""

ARGS_HELP = "OLD NEW, or REV [FILE...], or REV1..REV2 [-- PATH...]; options go anywhere before '--'"


def register(sub) -> None:
    p = sub.add_parser("diff", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    # everything from the first ARG on is read by _arguments, so that '--' ends the options as
    # git's does wherever it stands (argparse would let options after it through, and refuses
    # paths after '--' once an option came between them and the revisions)
    p.add_argument("args", nargs=argparse.REMAINDER, metavar="ARG", help=ARGS_HELP)
    _options(p)
    p.set_defaults(run=run)


def _options(p) -> None:
    from sgt_tui.commands.common import ENGINE_CHOICES

    p.add_argument("--format", choices=("text", "json"), default="text", help="text (default) or JSON on stdout")
    p.add_argument("--color", choices=("auto", "always", "never"), default="auto",
                   help="colour the text: auto (a terminal, and no NO_COLOR), always, never")
    p.add_argument("--timing", choices=("estimate", "speech"), default="estimate",
                   help="word times from the text (default, fast) or from the speech (espeak-ng/recordings; cached)")
    p.add_argument("--all", action="store_true", help="also list the utterances that did not change")
    p.add_argument("--exit-code", action="store_true", help="exit 1 when any script differs")
    p.add_argument("--render", metavar="DIR", help="also write a before/after animation of each changed utterance here")
    p.add_argument("--video", action="store_true", help="with --render: MP4s with the speech instead of GIFs")
    p.add_argument("--engine", choices=ENGINE_CHOICES, help="with --render: the engine (default neural)")
    p.add_argument("--size", metavar="WxH", default="240x240", help="with --render: one panel's size (default 240x240)")


def _arguments(args) -> tuple[argparse.Namespace, list[str], list[str] | None]:
    """The options, the arguments before '--' and the paths after it (None: no '--'), as git
    reads them: options anywhere before the first '--', everything after it a path."""
    rest = list(args.args)
    after = None
    if "--" in rest:
        at = rest.index("--")
        rest, after = rest[:at], rest[at + 1 :]
    parser = argparse.ArgumentParser(prog="sgt diff", description=DESCRIPTION,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("args", nargs="*", metavar="ARG", help=ARGS_HELP)
    _options(parser)
    known = argparse.Namespace(**{k: v for k, v in vars(args).items() if k != "args"})
    options = parser.parse_intermixed_args(rest, namespace=known)
    return options, options.args, after


def run(args) -> int:
    from pathlib import Path

    from sgt_tui.commands.common import use_color
    from sgt_tui.diffing import DiffInputError, json_diff, pairs_for
    from sgt_tui.errors import InputError, UsageError

    args, head, paths = _arguments(args)
    try:
        pairs = pairs_for(head, paths)
    except DiffInputError as exc:
        raise (UsageError if exc.usage else InputError)(str(exc)) from None
    from dsl.diff import DIFF_FORMAT, DIFF_VERSION, diff_scripts  # lazy: the compiler

    diffs = [diff_scripts(p.old_text, p.new_text, old_name=p.old_name, new_name=p.new_name, old_path=p.old_path,
                          new_path=p.new_path, timing=args.timing) for p in pairs]
    if args.format == "json":
        doc = {"format": DIFF_FORMAT, "version": DIFF_VERSION, "scripts": [d.to_dict(include_same=args.all) for d in diffs]}
        sys.stdout.write(json_diff(doc) + "\n")
    else:
        from sgt_tui.diffing import format_diff

        color = args.color == "always" or (args.color == "auto" and use_color(sys.stdout))
        text = "".join(format_diff(d, color=color, include_same=args.all) for d in diffs)
        sys.stdout.write(text or "no scripts to compare\n")
    if args.render:
        from sgt_tui.commands.render import parse_size
        from sgt_tui.diffing import render_changes

        made = render_changes(pairs, diffs, Path(args.render), engine=args.engine, size=parse_size(args.size),
                              video=args.video)
        print(f"wrote {len(made)} before/after render{'s' if len(made) != 1 else ''} into {args.render}", file=sys.stderr)
    differs = any(d.changed for d in diffs)
    return 1 if args.exit_code and differs else 0
