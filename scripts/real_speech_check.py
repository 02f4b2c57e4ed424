"""Does the generator behave on real human speech, with pauses and long gaps between sentences?

Recorded human speech that Debian packages (no internet needed; ``scripts/install.sh``
installs both):

- ``alsa``: alsa-utils' channel test phrases ("Front left", ...; one speaker, 8 phrases);
- ``audiobook``: pocketsphinx-testdata's LibriVox clips of *Sense and Sensibility* (a reader,
  5 sentences);
- ``cards``: pocketsphinx-testdata's "cards" utterances ("ten of clubs", ...; 5 phrases).

Each set's clips are joined into one recording with gaps that alternate between short
(0.4 s) and long (4 s), as a performance with pauses would have them; the gaps are either
digital zeros (``zeros``) or the recording's own background noise (``room``: its quietest
0.1 s, repeated). Word times come from pocketsphinx, aligned clip by clip. The same sentences
spoken by espeak-ng with the same gaps (``espeak-ng``) are the TTS comparison. For each, the
shipped model (or ``--weights``) generates ``--seeds`` takes and the script reports:

- wrist speed while speaking (frames inside a word) and while silent (frames more than
  ``QUIET_AFTER`` s after the last word and ``QUIET_BEFORE`` s before the next: the middle of
  the long gaps, where a speaker rests; the teacher needs about a second to lower its arms
  after speaking), their ratio (target at least 2) and the fastest silent frame (``max``);
- the Pearson correlation of the wrists' speed with the speech energy (the last audio
  feature, dB re the speech level / 20 + 1), per take, averaged (target at least 0.4): per
  frame (``corr``), and of their 1 s moving averages (``corr 1s``: whether the hands move
  while the voice is loud and rest while it is quiet, whatever the exact frame);
- the beat alignment of the motion with the speech onsets (docs/metrics.md), and the same
  motion against the onsets of another set's recording (``BA shuffled``, the chance level).

    python scripts/real_speech_check.py [--weights FILE] [--out DIR] [--seeds N] [--engine ENGINE] [--json FILE]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from model.engines import DEFAULT_ENGINE, ENGINES

ALSA = Path("/usr/share/sounds/alsa")
PHRASES = ["Front_Left", "Front_Center", "Front_Right", "Rear_Left", "Rear_Center", "Rear_Right", "Side_Left", "Side_Right"]
SPHINX = Path("/usr/share/pocketsphinx/test/data")
GAPS_S = (0.4, 4.0)  # the gaps after each clip alternate between these
QUIET_AFTER, QUIET_BEFORE = 1.0, 0.8  # silent frames: this far from the words around them
ROOM_SLICE_S = 0.1
ENVELOPE_FRAMES = 15  # 1 s moving average for the envelope correlation


def _transcripts(path: Path) -> dict[str, str]:
    """pocketsphinx's ``<s> words </s> (id)`` transcription lines -> {id: words}."""
    out = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        if "(" in line:
            text, key = line.rsplit("(", 1)
            out[key.strip(" )")] = " ".join(w for w in text.split() if w not in ("<s>", "</s>"))
    return out


def recording_sets() -> dict[str, list[tuple[Path, str]]]:
    """Every set of recordings installed: name -> [(wav, transcript)]."""
    sets = {}
    if (ALSA / "Front_Left.wav").exists():
        sets["alsa"] = [(ALSA / f"{p}.wav", p.replace("_", " ").lower()) for p in PHRASES]
    for name, folder, listing in (("audiobook", "librivox", "transcription"), ("cards", "cards", "cards.transcription")):
        if (SPHINX / folder / listing).exists():
            texts = _transcripts(SPHINX / folder / listing)
            sets[name] = [(SPHINX / folder / f"{key}.wav", text) for key, text in sorted(texts.items())]
    return sets


def _mono(path: Path, rate: int) -> np.ndarray:
    from model.features import load_audio

    return load_audio(path, rate)


def _room_noise(y: np.ndarray, rate: int, n: int) -> np.ndarray:
    """``n`` samples of the recording's own background: its quietest slice, repeated."""
    k = int(ROOM_SLICE_S * rate)
    starts = np.arange(0, max(1, len(y) - k), k // 2)
    quiet = min(starts, key=lambda s: float(np.mean(y[s:s + k] ** 2)))
    return np.resize(y[quiet:quiet + k], n).astype(np.float32)


def join(parts: list[np.ndarray], words: list[list], rate: int, gap_kind: str):
    """One recording of ``parts`` with the alternating gaps; words shifted onto it."""
    out, timed, t = [], [], 0.0
    for i, (y, ws) in enumerate(zip(parts, words)):
        out.append(y)
        timed += [(w, a + t, b + t) for w, a, b in ws]
        t += len(y) / rate
        gap = int(GAPS_S[i % 2] * rate) if i < len(parts) - 1 else 0
        out.append(np.zeros(gap, np.float32) if gap_kind == "zeros" else _room_noise(y, rate, gap))
        t += gap / rate
    return np.concatenate(out), timed


def speak_set(clips, out: Path, gap_kind: str, tts: bool, rate: int = 16000):
    """(wav path, timed words) of a set: the recordings (aligned) or espeak-ng's take of them."""
    import io

    import soundfile as sf

    from core.fileio import atomic_write
    from dsl.parser import WORD_RE
    from dsl.speech import load_recording, synthesize

    parts, words = [], []
    for wav, text in clips:
        spans = [(m.start(), m.end()) for m in WORD_RE.finditer(text)]
        speech = synthesize(text, spans) if tts else load_recording(wav, text, spans)
        parts.append(_mono(speech.audio_path, rate))
        words.append([(w.word, w.start, w.end) for w in speech.words])
    y, timed = join(parts, words, rate, gap_kind)
    path = out / f"{clips[0][0].parent.name}_{'tts' if tts else gap_kind}.wav"
    buf = io.BytesIO()
    sf.write(buf, y, rate, format="WAV")
    atomic_write(path, buf.getvalue())
    return path, timed


def frame_masks(words, n: int, lead: float) -> tuple[np.ndarray, np.ndarray]:
    """(speaking, silent) frame masks: inside a word; far enough from every word."""
    from core.skeleton import FPS

    t = np.arange(n) / FPS - lead
    speaking = np.zeros(n, bool)
    near = np.zeros(n, bool)
    for _, a, b in words:
        speaking |= (t >= a) & (t < b)
        near |= (t >= a - QUIET_BEFORE) & (t < b + QUIET_AFTER)
    after_first = t >= words[0][1] if words else np.ones(n, bool)
    return speaking, ~near & after_first


def measure(poses, feats, speaking, silent, other_feats) -> dict:
    from core.skeleton import JOINTS
    from model.training.metrics import clips_beat_alignment, joint_speeds

    wrists = [JOINTS.index("left_wrist"), JOINTS.index("right_wrist")]
    speed = np.r_[0.0, joint_speeds(poses)[:, wrists].mean(axis=1)]  # speed of frame t: the step into it
    energy = feats[:, -1]
    kernel = np.ones(ENVELOPE_FRAMES) / ENVELOPE_FRAMES

    def corr(a, b):
        return float(np.corrcoef(a, b)[0, 1]) if a.std() > 0 and b.std() > 0 else float("nan")

    other = other_feats[np.arange(len(feats)) % len(other_feats)]
    return {"speaking": float(speed[speaking].mean()), "silent": float(speed[silent].mean()) if silent.any() else float("nan"),
            "silent_max": float(speed[silent].max()) if silent.any() else float("nan"),
            "corr": corr(energy[1:], speed[1:]),
            "corr_1s": corr(np.convolve(energy[1:], kernel, "valid"), np.convolve(speed[1:], kernel, "valid")),
            "ba": clips_beat_alignment([poses], [feats]), "ba_shuffled": clips_beat_alignment([poses], [other])}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--weights", help="generator weights (default: the shipped ones)")
    ap.add_argument("--out", default="out/real_speech", help="working folder (default out/real_speech)")
    ap.add_argument("--seeds", type=int, default=5, help="takes per condition (default 5)")
    ap.add_argument("--engine", choices=tuple(ENGINES), default=DEFAULT_ENGINE)
    ap.add_argument("--json", metavar="FILE", help="also write every row and the human-speech summary as JSON")
    args = ap.parse_args()
    sets = recording_sets()
    if not sets:
        print(f"no recordings in {ALSA} or {SPHINX}: apt-get install alsa-utils pocketsphinx-testdata", file=sys.stderr)
        return 1
    from core.controls import ControlArrays
    from core.skeleton import FPS, frame_count
    from core.words import TimedWord
    from model import neural
    from model.features import audio_features, load_audio
    from model.generate import NETWORK_ENGINES, EngineInputs, engine_function

    # --weights: the network engines' (default: each its shipped file); the other engines their defaults
    fn = engine_function(args.engine, neural.Options(weights=args.weights) if args.engine in NETWORK_ENGINES else None)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    lead, tail = 0.5, 1.0
    takes = {}
    for name, clips in sets.items():
        for kind, tts in (("zeros", False), ("room", False), ("espeak-ng", True)):
            path, words = speak_set(clips, out, kind if not tts else "zeros", tts)
            y = load_audio(path)
            n = frame_count(lead + len(y) / 16000 + tail)
            feats = audio_features(y, n, round(lead * FPS))
            timed = [TimedWord(w, a + lead, b + lead) for w, a, b in words]
            takes[(name, kind)] = (EngineInputs(ControlArrays.empty(n), timed, path, lead), feats, words)
    names = list(sets)
    rows = []
    for (name, kind), (inputs, feats, words) in takes.items():
        other = takes[(names[(names.index(name) + 1) % len(names)], kind)][1] if len(names) > 1 else feats[::-1]
        speaking, silent = frame_masks(words, inputs.n_frames, lead)
        results = []
        for seed in range(args.seeds):
            poses = fn(inputs, seed=seed)
            results.append(measure(poses, feats, speaking, silent, other))
        mean = {k: float(np.nanmean([r[k] for r in results])) for k in results[0]}
        rows.append((name, kind, len(words), inputs.n_frames / FPS, mean))
    print(f"{'set':10} {'gaps':10} {'words':>5} {'dur s':>6} {'speak m/s':>9} {'silent':>7} {'max':>6} {'ratio':>6} "
          f"{'corr':>5} {'corr 1s':>7} {'BA':>5} {'BA shuf':>7}")
    for name, kind, nw, dur, m in rows:
        print(f"{name:10} {kind:10} {nw:5d} {dur:6.1f} {m['speaking']:9.3f} {m['silent']:7.3f} {m['silent_max']:6.3f} "
              f"{m['speaking'] / m['silent']:6.2f} {m['corr']:5.2f} {m['corr_1s']:7.2f} {m['ba']:5.2f} {m['ba_shuffled']:7.2f}")
    human = [m for _, kind, _, _, m in rows if kind != "espeak-ng"]
    summary = {"ratio": float(np.mean([m["speaking"] / m["silent"] for m in human])),
               "corr": float(np.mean([m["corr"] for m in human])), "corr_1s": float(np.mean([m["corr_1s"] for m in human])),
               "ba": float(np.mean([m["ba"] for m in human])), "ba_shuffled": float(np.mean([m["ba_shuffled"] for m in human]))}
    print(f"human speech ({len(human)} recordings x {args.seeds} takes, {args.engine}): speaking/silent ratio "
          f"{summary['ratio']:.2f}, correlation with loudness {summary['corr']:.2f} per frame, {summary['corr_1s']:.2f} "
          f"over 1 s, BA {summary['ba']:.2f} (shuffled {summary['ba_shuffled']:.2f})")
    if args.json:
        import json

        from core.fileio import atomic_write_text

        data = {"engine": args.engine, "weights": args.weights, "seeds": args.seeds, "human": summary,
                "rows": [{"set": name, "gaps": kind, "words": nw, "seconds": dur, **m} for name, kind, nw, dur, m in rows]}
        atomic_write_text(Path(args.json), json.dumps(data, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
