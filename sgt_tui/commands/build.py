"""sgt build: every script under some paths -> motion files and exports, incrementally."""

from __future__ import annotations

import argparse
import sys

from core.counting import plural

HELP = "build every script under PATHS into OUT (incremental, cached, parallel)"
DESCRIPTION = """\
Build every .sgt script under PATHS (folders are searched recursively) into the folder
OUT: a motion file per script (OUT/<path>.json, mirroring the sources), plus --bvh, --glb
and --wav (one WAV per utterance), and OUT/manifest.json listing every output with its
sha256 and, per utterance, its cache key and whether this build took it from the cache.

Each utterance is cached by the content of everything that changes its motion (text,
controls, the gestures they play, voice, rate, pitch, recordings, engine, weights or
matching database, seed), so editing one line regenerates one utterance, and a build
with nothing changed writes nothing. Outputs are written atomically: a killed build
leaves no half-written file and the next one finishes it; an output that no longer
matches the manifest (changed
or removed) is made again and reported. One build at a time writes OUT: a second one waits
for it (--no-wait: fails instead). Scripts with errors are reported (every problem, as
'sgt check' does), as is a script whose output would be one of the build's inputs (its
recording or timings file, another script); the others still build; the exit status is 1
when anything failed. Warnings are printed as 'sgt check --timing' prints them, once per
script.

--jobs N runs N local worker processes with one torch thread each; --ray runs the same
work on Ray (a local instance, or a cluster at ADDRESS; pip install -e '.[ray]')."""


def register(sub) -> None:
    from sgt_tui.commands.common import DEFAULT_ENGINE, ENGINE_CHOICES, add_database_option, add_post_options, add_seed_option, positive_int
    from sgt_tui.commands.generate import ENGINE_HELP

    p = sub.add_parser("build", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("paths", nargs="+", metavar="PATH", help="script files or folders of scripts")
    p.add_argument("-o", "--output", metavar="OUT", required=True, help="output folder (created if missing)")
    p.add_argument("--bvh", action="store_true", help="also write OUT/<path>.bvh (every utterance, one after another)")
    p.add_argument("--glb", action="store_true", help="also write OUT/<path>.glb (glTF, sgt's rig)")
    p.add_argument("--wav", action="store_true", help="also write the speech, OUT/<path>_NNN.wav per utterance")
    p.add_argument("-j", "--jobs", type=positive_int, metavar="N", help="local worker processes (default: the CPUs available)")
    p.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="run on Ray: a local instance, or the cluster at ADDRESS ('auto', 'ray://HOST:10001')")
    p.add_argument("--cache", metavar="DIR", help="the utterance cache (default: build/ in the sgt cache, $SGT_CACHE_DIR)")
    p.add_argument("--engine", choices=ENGINE_CHOICES, default=DEFAULT_ENGINE, help=ENGINE_HELP)
    add_seed_option(p, "random seed for every script (default: each script's @seed)")
    add_post_options(p)
    p.add_argument("--weights", metavar="PATH", help="generator weights (default: the shipped model/weights/generator.pt)")
    add_database_option(p)
    p.add_argument("--auto-gestures", action="store_true",
                   help="where a script has no mark, the gestures its words call for ('sgt suggest' shows them)")
    p.add_argument("--no-wait", action="store_true",
                   help="when another build is writing OUT, fail at once (exit 1) instead of waiting for it")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar, no warnings, no summary: only errors")
    p.set_defaults(run=run)


def run(args) -> int:
    from pathlib import Path

    from core.workers import default_jobs
    from sgt_tui.build import BuildCache, Settings, build, find_sources
    from sgt_tui.build.lock import Busy
    from sgt_tui.build.runners import RunnerError
    from sgt_tui.commands.common import database_option, existing_file, output_folder, print_diagnostics
    from sgt_tui.errors import InputError, UsageError
    from sgt_tui.progress import BuildProgress

    out = output_folder(args.output)
    cache = BuildCache(output_folder(args.cache, "--cache") if args.cache else None)
    weights = str(existing_file(args.weights).resolve()) if args.weights else None
    database = database_option(args.database, args.engine)
    database = str(Path(database).resolve()) if database else None
    settings = Settings(engine=args.engine, seed=args.seed, smoothing=args.smoothing, blend=not args.no_blend, weights=weights,
                        database=database,
                        take_posture=not args.no_take_posture, auto_gestures=args.auto_gestures)
    exports = [name for name in ("bvh", "glb", "wav") if getattr(args, name)]
    if args.ray is not None and args.jobs is not None and args.ray:
        raise UsageError("--jobs sets the workers of a local build or a local Ray instance; a Ray cluster has its own")

    def show(diags, sources) -> None:
        if args.quiet:
            diags = [d for d in diags if d.is_error]
        print_diagnostics(diags, sources, summarise=False)

    if not find_sources([Path(p) for p in args.paths]):
        raise UsageError(f"no .sgt scripts under {' '.join(args.paths)}")
    def waiting(holder: str) -> None:  # shown with --quiet too: a build that waits says why
        who = f" ({holder})" if holder else ""
        print(f"sgt build: waiting for another build into {out} to finish{who}; --no-wait fails instead",
              file=sys.stderr, flush=True)

    progress = None if args.quiet else BuildProgress()
    try:
        report = build([Path(p) for p in args.paths], out, settings, jobs=args.jobs or default_jobs(),
                       ray=(args.ray or True) if args.ray is not None else None, exports=exports, cache=cache,
                       show=show, progress=progress, wait=not args.no_wait, waiting=waiting)
    except RunnerError as exc:
        raise (UsageError if "pip install" in str(exc) else InputError)(str(exc)) from None
    except Busy as exc:
        raise InputError(str(exc)) from None
    if not args.quiet:
        for rel, why in report.repaired:
            print(f"sgt build: warning: {out / rel} did not match the manifest ({why} since the last build): "
                  f"made again", file=sys.stderr)
    for line in report.warnings:
        print(f"sgt build: warning: {line}", file=sys.stderr)
    for line in report.errors:
        print(f"sgt build: error: {line}", file=sys.stderr)
    if not args.quiet or report.failed:
        ok = report.scripts - len(report.failed)
        failed = f", {len(report.failed)} failed ({', '.join(report.failed[:5])}{', ...' if len(report.failed) > 5 else ''})" if report.failed else ""
        print(f"built {ok} of {plural(report.scripts, 'script')} into {out}{failed}: "
              f"{plural(report.generated, 'utterance')} generated, {report.cached} cached, "
              f"{plural(report.up_to_date, 'script')} up to date", file=sys.stderr)
    return 1 if report.failed else 0
