"""No command line gives a traceback: random arguments for every command.

Hypothesis builds command lines from each command's options with random values (numbers out
of range, nan, words, odd sizes) and paths of every kind: scripts with and without errors,
motion files, folders, missing paths, paths under a file, device nodes (/dev/null- and
/dev/full-like, made in the test's folder when running as root), FIFOs, symbolic links,
kernel files nobody may write, and ``-``. Whatever happens, the command returns 0, 1 or 2,
prints a message when it fails, no exception escapes and no traceback reaches stderr; and no
device, FIFO or link in the world was replaced.

Inputs stay cheap: tiny scripts, the keyframe and rules engines mostly, small render sizes;
no valid corpus exists, so train and eval stop at their checks.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import os
import signal
import stat
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from special_files import IS_ROOT, FifoReader, FifoWriter, char_device
from test_fuzz import EXAMPLES, _mutate, script_text

from sgt_tui.cli import main

SCRIPT = "guide: Hello [pose:wave] there.\nguide: And once more.\n"


class World:
    """Files of every kind in one folder, the current folder while a command runs."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.counter = itertools.count()
        (root / "ok.sgt").write_text(SCRIPT)
        (root / "bad.sgt").write_text("@seed x\nguide: hi [pose:point_rigth] <speed:9>there\n")
        (root / "empty.sgt").write_text("")
        (root / "notes.txt").write_text("hello")
        (root / "junk.json").write_text("{not json")
        (root / "junk.npz").write_bytes(b"not a zip")
        (root / "folder").mkdir()
        (root / "folder.sgt").mkdir()
        (root / "folder.json").mkdir()
        (root / "corpus").mkdir()
        (root / "exists.json").write_text("{}")
        assert main(["generate", str(root / "ok.sgt"), "-o", str(root / "take.json"), "--engine", "keyframe"]) == 0
        assert main(["export", str(root / "take.json"), "-o", str(root / "take.npz")]) == 0
        (root / "link.json").symlink_to(root / "linked-target.json")  # dangling until written
        (root / "link-to-take.json").symlink_to("take.json")
        (root / "loop.json").symlink_to("loop.json")
        self.specials: dict[Path, str] = {}
        if IS_ROOT:  # the machine's own devices are never used: a regression would replace them
            self.null = str(char_device(root / "null"))
            self.full = str(char_device(root / "full", like="/dev/full"))
            self.specials[Path(self.null)] = "chr"
            self.specials[Path(self.full)] = "chr"
        else:  # an ordinary user cannot replace these
            self.null, self.full = "/dev/null", "/dev/full"
        self.drain = FifoReader(root / "drain.json")  # an output FIFO with a reader
        self.feed = FifoWriter(root / "feed.sgt", SCRIPT.encode())  # an input FIFO with a writer
        self.specials[root / "drain.json"] = "fifo"
        self.specials[root / "feed.sgt"] = "fifo"
        self.specials[root / "link.json"] = "link"
        self.specials[root / "link-to-take.json"] = "link"

    def close(self) -> None:
        self.drain.close()
        self.feed.close()

    def intact(self) -> list[str]:
        """The special files that are no longer what they were."""
        kinds = {"chr": stat.S_ISCHR, "fifo": stat.S_ISFIFO, "link": stat.S_ISLNK}
        return [str(p) for p, kind in self.specials.items() if not kinds[kind](os.lstat(p).st_mode)]


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    root = tmp_path_factory.mktemp("world")
    w = World(root)
    yield w
    w.close()


@pytest.fixture(autouse=True)
def inside(world, monkeypatch):
    monkeypatch.chdir(world.root)  # default outputs (./STEM_speech, data/corpus, runs/...) land here
    monkeypatch.setenv("HOME", str(world.root))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(world.root / "config"))
    monkeypatch.delenv("SGT_LIBRARY_PATH", raising=False)


# -- values ----------------------------------------------------------------------------------
# A command line is "tame" (every value valid, so that commands run to the end and write
# their outputs: new files, devices, FIFOs, links, stdout), has "a few" wild values among
# valid ones (each reaches deep into the command), or is "wild" throughout.

# Text as a command line carries it: any character but NUL, and bytes that are not UTF-8
# (Python keeps them as lone surrogates, U+DC80..U+DCFF).
words = st.text(alphabet=st.one_of(st.characters(codec="utf-8", exclude_characters="\x00"),
                                   st.characters(min_codepoint=0xDC80, max_codepoint=0xDCFF)), max_size=12)
# Random names used as paths stay inside the world: never absolute, never "..".
names = words.map(lambda s: s.lstrip("/").replace("..", "_"))
small = st.integers(0, 1).map(str)
numbers = st.one_of(st.integers(-5, 60).map(str),
                    st.sampled_from(["2147483648", "-2147483649", "1e9", "nan", "inf", "-0", "0x10", "", "3.5", "seven"]),
                    words)
floats = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32).map(str),
                   st.sampled_from(["0", "-1", "1e-7", "nan", "inf", "x"]))
valid_size = st.tuples(st.integers(16, 40), st.integers(16, 40)).map(lambda t: f"{t[0]}x{t[1]}")
sizes = st.one_of(st.tuples(st.integers(-5, 64), st.integers(-5, 64)).map(lambda t: f"{t[0]}x{t[1]}"),
                  st.sampled_from(["5000x5000", "32×32", "x", "", "32x", "16x16x16"]), words)


class Values:
    """Strategies for one command line: tame, a few wild values, or wild."""

    WILDNESS = {"tame": 0, "few": 3, "wild": 12}  # in 20ths: how often a value is drawn wild

    def __init__(self, world: World, data) -> None:
        self.w, self.data = world, data
        self.mode = data.draw(st.sampled_from(list(self.WILDNESS)))
        self.tame = self.mode == "tame"

    def pick(self, tame, wild):
        """``tame``, or ``wild`` as often as the mode says."""
        if self.tame or self.data.draw(st.integers(0, 19)) >= self.WILDNESS[self.mode]:
            return tame
        return wild

    def number(self):
        return self.pick(small, numbers)

    def size(self):
        return self.pick(valid_size, sizes)

    def engine(self):
        return self.pick(st.sampled_from(["keyframe", "rules"]), st.sampled_from(["neural", "nope", ""]))

    def choice(self, valid: list[str], invalid: list[str]):
        return self.pick(st.sampled_from(valid), st.sampled_from(invalid) | words)

    def input(self, *good: str):
        r = self.w.root
        odd = [str(r / n) for n in ("missing.sgt", "folder", "folder.sgt", "folder.json", "notes.txt", "junk.json",
                                    "junk.npz", "ok.sgt/x.sgt", "bad.sgt", "empty.sgt", "feed.sgt", "loop.json",
                                    "link-to-take.json", "exists.json")]
        odd += [self.w.null, "", "-", "nope"]
        return self.pick(st.sampled_from([str(r / g) for g in good]), st.sampled_from(odd) | names)

    def output(self, *suffixes: str, binary: bool = False):
        """New files named with one of ``suffixes``; when tame also a device, a FIFO, a link, stdout."""
        r = self.w.root

        def fresh(suffix: str) -> str:
            return str(r / "out" / f"{next(self.w.counter)}{suffix}")

        special = [str(r / "drain.json"), str(r / "link.json"), self.w.null, "-"]
        tame = st.one_of(st.sampled_from(suffixes).map(fresh), st.sampled_from(special))
        odd = [str(r / n) for n in ("folder", "folder.json", "ok.sgt/x.json", "exists.json", "link-to-take.json",
                                    "loop.json", "missing-dir/deeper/x.json")]
        odd += [self.w.full, "", "/proc/version", "/sys/kernel/notes", ".", f"{r}/x.json/"]
        return self.pick(tame, st.sampled_from(odd) | names)

    def folder(self):
        r = self.w.root
        # (no FIFO: folders are inputs too (--corpus, --data), and reading the drained FIFO
        # would wait for a writer forever, as `cat` does)
        odd = [str(r / n) for n in ("folder", "ok.sgt", "ok.sgt/sub", "missing/deeper", "feed.sgt", "corpus")]
        odd += [self.w.null, "-", "", "/proc/sys-nope", "/sys/kernel"]
        return self.pick(st.sampled_from([str(r / "out" / f"dir{n}") for n in range(3)]), st.sampled_from(odd) | names)


# -- command lines ---------------------------------------------------------------------------


def chance(data, p: float) -> bool:
    return data.draw(st.integers(0, 19)) < round(p * 20)


def option(data, argv: list[str], flag: str, values, p: float = 0.5) -> None:
    if chance(data, p):
        argv += [flag, data.draw(values)]


def flag(data, argv: list[str], name: str, p: float = 0.3) -> None:
    if chance(data, p):
        argv.append(name)


def command_line(name: str, data, w: World) -> list[str]:
    v = Values(w, data)
    argv = [name]
    if name == "check":
        argv += data.draw(st.lists(v.input("ok.sgt", "bad.sgt"), min_size=1, max_size=3))
        option(data, argv, "--format", v.choice(["text", "json"], ["xml"]))
        flag(data, argv, "--timing", 0.2)
        flag(data, argv, "-q")
    elif name == "compile":
        argv.append(data.draw(v.input("ok.sgt", "bad.sgt")))
        option(data, argv, "-o", v.output(".json"), 0.7)
        option(data, argv, "--npz", v.output(".npz"), 0.3)
        option(data, argv, "--utterance", v.number(), 0.3)
        flag(data, argv, "--estimate", 0.8)
        option(data, argv, "--format", v.choice(["text", "json"], ["?"]), 0.2)
    elif name == "say":
        argv.append(data.draw(v.input("ok.sgt", "bad.sgt")))
        option(data, argv, "-o", v.folder(), 0.8)
        option(data, argv, "--utterance", v.number(), 0.3)
        flag(data, argv, "--json")
    elif name == "library":
        sub = data.draw(v.choice(["list", "show", "add"], ["", "nope"]))
        argv += [sub] if sub else []
        if sub == "list":
            option(data, argv, "--tag", v.choice(["deictic", "beat"], ["nope"]), 0.3)
            flag(data, argv, "--json")
            option(data, argv, "--dir", v.folder(), 0.3)
        elif sub == "show":
            argv.append(data.draw(v.choice(["wave", "nod", "point_right"], ["nope"])))
            option(data, argv, "--speed", v.choice(["1", "2", "3"], ["0", "x"]), 0.3)
            flag(data, argv, "--flip")
            flag(data, argv, "--json")
            option(data, argv, "--dir", v.folder(), 0.2)
        elif sub == "add":
            argv.append(data.draw(v.choice(["mine", "x1"], ["Bad Name"])))
            argv += ["--from", data.draw(v.input("take.json", "take.npz"))]
            argv += ["--frames", data.draw(v.choice(["0:8", "2:10"], ["5:5", "0:9999", ":", "a:b"]))]
            option(data, argv, "--utterance", v.number(), 0.3)
            option(data, argv, "--to", v.folder(), 0.8)
            option(data, argv, "--stroke", v.choice(["4"], ["-1", "99", "x"]), 0.3)
            option(data, argv, "--tags", words, 0.2)
            option(data, argv, "--description", words, 0.2)
            flag(data, argv, "--force", 0.5)
    elif name in ("generate", "render", "export"):
        if name == "generate":
            argv.append(data.draw(v.input("ok.sgt", "bad.sgt")))
            argv += ["-o", data.draw(v.output(".json", ".npz"))]
            option(data, argv, "--format", v.choice(["json", "npz"], ["csv"]), 0.2)
            option(data, argv, "--utterance", v.number(), 0.3)
            option(data, argv, "--smoothing", v.choice(["one_euro", "none", "moving_average"], ["?"]), 0.2)
            flag(data, argv, "--no-blend", 0.2)
            if not v.tame:
                option(data, argv, "--weights", v.input("take.json"), 0.2)
        elif name == "render":
            argv.append(data.draw(v.input("take.json", "take.npz", "ok.sgt")))
            argv += ["-o", data.draw(v.output(".gif"))]
            option(data, argv, "--sheet", v.output(".png"), 0.3)
            option(data, argv, "--compare", v.input("take.json", "take.npz"), 0.2)
            argv += ["--size", data.draw(v.size())]
            option(data, argv, "--utterance", v.number(), 0.3)
        else:
            argv.append(data.draw(v.input("take.json", "take.npz", "ok.sgt")))
            argv += ["-o", data.draw(v.output(".bvh", ".csv", ".json", ".npz"))]
            option(data, argv, "--format", v.choice(["bvh", "csv", "json", "npz"], ["obj"]), 0.3)
            option(data, argv, "--utterance", v.number(), 0.3)
        argv += ["--engine", data.draw(v.engine())]
        option(data, argv, "--seed", v.number(), 0.3)
    elif name == "build":
        argv += data.draw(st.lists(v.input("ok.sgt", "bad.sgt", "folder") | v.folder(), min_size=1, max_size=3))
        argv += ["-o", data.draw(v.folder())]
        option(data, argv, "--cache", v.folder(), 0.3)
        for name_ in ("--bvh", "--glb", "--wav", "-q"):
            flag(data, argv, name_, 0.3)
        option(data, argv, "--jobs", v.choice(["1"], ["0", "-1", "x"]), 0.5)
        argv += ["--engine", data.draw(v.engine())]
        option(data, argv, "--seed", v.number(), 0.3)
    elif name == "corpus":  # never a valid --hours: a real corpus build takes minutes
        option(data, argv, "-o", v.folder(), 0.8)
        argv += ["--hours", data.draw(st.sampled_from(["0", "-1", "nan", "inf", "x", "", "-0.5"]))]
        option(data, argv, "--seed", v.number(), 0.3)
        option(data, argv, "--jobs", v.number(), 0.3)
    elif name == "train":  # no valid corpus or data folder exists: it stops at its checks
        source = data.draw(st.sampled_from(["--corpus", "--data", None]))
        if source:
            argv += [source, data.draw(v.folder() | v.input("corpus"))]
        option(data, argv, "-o", v.folder(), 0.5)
        for opt in ("--epochs", "--steps", "--batch", "--threads", "--hidden", "--smooth", "--seed", "--window"):
            option(data, argv, opt, v.number(), 0.15)
        for opt in ("--minutes", "--ctrl-weight", "--style-weight", "--vel-weight", "--kl", "--p-prior", "--restyle"):
            option(data, argv, opt, floats, 0.15)
    elif name == "eval":
        option(data, argv, "--corpus", v.folder() | v.input("corpus"), 0.9)
        option(data, argv, "--split", v.choice(["test", "val", "train"], ["dev"]), 0.3)
        if not v.tame:
            option(data, argv, "--weights", v.input("take.json"), 0.2)
            option(data, argv, "--extractor", v.input("take.json"), 0.2)
        option(data, argv, "-o", v.output(".json"), 0.4)
        option(data, argv, "--limit", v.pick(st.just("1"), numbers), 0.3)
        option(data, argv, "--seed", v.number(), 0.2)
    elif name == "edit":  # stdin is not a terminal under pytest: it stops after opening the file
        argv.append(data.draw(v.input("ok.sgt")))
        option(data, argv, "--engine", v.engine(), 0.3)
    if v.mode == "wild" and data.draw(st.integers(0, 9)) == 9:  # now and then an option no command has
        argv.append(data.draw(st.sampled_from(["--nope", "-x", "--", "--help"])))
    return argv


class Hung(Exception):
    pass


@contextlib.contextmanager
def time_limit(seconds: int, argv: list[str]):
    """Fail, rather than hang the suite, when a command waits for ever (a FIFO with no partner)."""
    def expire(signum, frame):
        raise Hung(f"no answer in {seconds} s: {argv}")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def run_once(argv: list[str], world: World) -> None:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), time_limit(300, argv):
        code = main(argv)  # any exception escaping here fails the test, with the command line
    message = err.getvalue()
    assert code in (0, 1, 2), (argv, code, message)
    assert "Traceback" not in message, (argv, message)
    if code:  # `sgt check` prints its diagnostics on stdout
        said = message + out.getvalue()
        assert "error" in said or "usage:" in said, (argv, code, said)
    assert not world.intact(), (argv, world.intact())


COMMANDS = {  # command -> examples: a few seconds each, the whole file well under two minutes
    "check": 40, "compile": 60, "say": 30, "library": 50, "generate": 50, "render": 15, "export": 50, "build": 15,
    "corpus": 15, "train": 30, "eval": 30, "edit": 20,
}


@pytest.mark.parametrize("command", list(COMMANDS))
def test_random_command_lines_never_give_a_traceback(command, world):
    @settings(max_examples=COMMANDS[command], deadline=None, derandomize=False, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
    @given(data=st.data())
    def check(data):
        run_once(command_line(command, data, world), world)

    check()


@settings(max_examples=80, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_random_scripts_through_compile_estimate(data, world):
    """`sgt compile --estimate` on random and mutated scripts: diagnostics (1) or a plan (0)."""
    text = data.draw(st.one_of(script_text, st.sampled_from(EXAMPLES).map(lambda t: _mutate(data, t))))
    path = world.root / "out" / f"fuzz{next(world.counter)}.sgt"
    path.parent.mkdir(exist_ok=True)
    path.write_bytes(text.encode("utf-8", errors="surrogatepass"))
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["compile", str(path), "--estimate", "-o", "-"])
    assert code in (0, 1), (text, code, err.getvalue())
    assert "Traceback" not in err.getvalue()
    if code == 0:
        import json

        plan = json.loads(out.getvalue())
        assert plan["format"] == "sgt-plan"
    else:
        assert "error" in err.getvalue()
