"""Does the generator behave on real human speech, not only on the TTS voices it was trained on?

The only recorded human speech on a Debian machine without internet is alsa-utils' channel
test set (/usr/share/sounds/alsa: "Front left", "Front center", ... spoken by a person). This
script joins the eight of them into one recording, writes a script that uses it with
``@audio`` (word timings from the offline pocketsphinx aligner), and compares the motion the
shipped model makes from it with the motion it makes from the same words spoken by espeak-ng
and from silence with the same word timings:

- mean wrist speed and jerk of each (real speech should sit near TTS speech, not blow up);
- the correlation of wrist speed with the speech energy envelope (the model should move with
  the voice, for the real voice as for TTS).

    python scripts/real_speech_check.py [--weights FILE] [--out DIR]

Needs ``apt-get install alsa-utils`` (scripts/install.sh installs it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ALSA = Path("/usr/share/sounds/alsa")
PHRASES = ["Front_Left", "Front_Center", "Front_Right", "Rear_Left", "Rear_Center", "Rear_Right", "Side_Left", "Side_Right"]
GAP_S = 0.5


def join_recordings(out_wav: Path) -> str:
    """Concatenate the alsa phrases with short gaps; return the transcript."""
    import io

    import soundfile as sf

    from core.fileio import atomic_write

    parts, rate = [], None
    for name in PHRASES:
        data, sr = sf.read(ALSA / f"{name}.wav", dtype="float32")
        rate = rate or sr
        if sr != rate:
            raise SystemExit(f"{name}.wav has sample rate {sr}, expected {rate}")
        parts += [data if data.ndim == 1 else data.mean(axis=1), np.zeros(int(GAP_S * rate), np.float32)]
    buf = io.BytesIO()
    sf.write(buf, np.concatenate(parts), rate, format="WAV")
    atomic_write(out_wav, buf.getvalue())
    return ". ".join(p.replace("_", " ").lower() for p in PHRASES).capitalize() + "."


def loudness(audio_path: Path, n_frames: int, lead_in: float) -> np.ndarray:
    """Per-frame log energy of the speech (15 fps), aligned with the motion."""
    from core.skeleton import FPS
    from model.features import audio_features, load_audio

    return audio_features(load_audio(audio_path), n_frames, offset_frames=int(round(lead_in * FPS)))[:, -1]


def speed_loudness_correlation(poses: np.ndarray, energy: np.ndarray) -> float:
    """Pearson correlation of mean wrist speed with the speech energy (both at 15 fps)."""
    from core.skeleton import JOINTS
    from model.training.metrics import joint_speeds

    wrists = [JOINTS.index("left_wrist"), JOINTS.index("right_wrist")]
    speed = joint_speeds(poses)[:, wrists].mean(axis=1)
    e = energy[1:]
    return float(np.corrcoef(e, speed)[0, 1]) if e.std() > 0 and speed.std() > 0 else float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--weights", help="generator weights (default: the shipped ones)")
    ap.add_argument("--out", default="out/real_speech", help="working folder (default out/real_speech)")
    ap.add_argument("--seeds", type=int, default=5, help="takes per condition (default 5)")
    args = ap.parse_args()
    if not (ALSA / "Front_Left.wav").exists():
        print(f"no recordings in {ALSA}: apt-get install alsa-utils", file=sys.stderr)
        return 1
    from core.fileio import atomic_write_text
    from dsl.compiler import compile_file
    from model import neural
    from model.generate import EngineInputs
    from model.training.metrics import group_statistics

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    text = join_recordings(out / "alsa_voice.wav")
    atomic_write_text(out / "real.sgt", f"@audio alsa_voice.wav\n{text}\n")
    atomic_write_text(out / "tts.sgt", f"{text}\n")
    options = neural.Options(weights=args.weights)
    rows = []
    for label, script in (("real voice", "real.sgt"), ("espeak-ng", "tts.sgt"), ("silence", "real.sgt")):
        result = compile_file(out / script)
        if result.plan is None:
            for d in result.diagnostics:
                print(d, file=sys.stderr)
            return 1
        u = result.plan.utterances[0]
        inputs = EngineInputs.from_plan(u)
        energy = None
        if label == "silence":  # same words and timings, no audio
            inputs = EngineInputs(inputs.arrays, inputs.words, None, inputs.lead_in)
        else:
            energy = loudness(u.audio_path, inputs.n_frames, u.lead_in)
        speeds, jerks, corrs = [], [], []
        for seed in range(args.seeds):
            poses = neural.generate(inputs, seed=seed, options=options)
            stats = group_statistics([poses], ["left_wrist", "right_wrist"])
            speeds.append(stats.speed)
            jerks.append(stats.jerk)
            if energy is not None:
                corrs.append(speed_loudness_correlation(poses, energy))
        corr = float(np.nanmean(corrs)) if corrs else float("nan")
        rows.append((label, len(u.words), u.duration, np.mean(speeds), np.mean(jerks), corr))
    print(f"{'speech':12} {'words':>5} {'dur s':>6} {'wrist m/s':>9} {'jerk m/s3':>9} {'corr(energy, speed)':>20}")
    for label, nw, dur, spd, jerk, corr in rows:
        c = "-" if corr != corr else f"{corr:.2f}"
        print(f"{label:12} {nw:5d} {dur:6.2f} {spd:9.3f} {jerk:9.2f} {c:>20}")
    print(f"({args.seeds} takes each; wrists; correlation of wrist speed with the energy envelope)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
