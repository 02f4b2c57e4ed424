"""The procedural training corpus: TTS speech + motion from the rule-based teacher.

No speech-gesture dataset can be downloaded, so the generator learns from synthetic clips:

- text: English sentences from Debian's fortunes files (``apt-get install fortunes
  fortunes-min``), cleaned (attributions, tabs, code-like and non-speech lines dropped) and
  cut into 3-25-word utterances, de-duplicated;
- speech: :func:`dsl.speech.synthesize` (espeak-ng) with several English voices and variants,
  rates 120-220 and pitches 30-70, sometimes with a pause at a comma; and, on
  :data:`FESTIVAL_SHARE` of the clips when Festival is installed, one of its three English
  voices (:mod:`model.training.voices`: two diphone voices and an HTS voice, word times from
  the engine);
- silence: :data:`GAP_SHARE` of the clips join two or three sentences with long gaps of
  silence between them (:data:`GAP_SECONDS`), digital zeros in the clean audio and noise in
  the augmented one, so the model learns that silence means rest (the teacher's speaking
  envelope drops to rest in gaps over about a second);
- motion: :func:`model.teacher.teach` with a random per-clip style (speed, space, handedness)
  and, for half of the clips, mirrored left/right (the stored style's handedness is negated);
- audio augmentation (so the model behaves on real recordings): a light tempo change
  (``librosa.effects.time_stretch``, word times rescaled; motion follows the new timing),
  then on 80 % of the clips pitch shift, random gain, a room-like reverb, a band limit and
  white or pink noise at 15-40 dB SNR. Every clip stores both ``audio`` (augmented features)
  and ``audio_clean`` (the features of the tempo-adjusted speech without the rest), so val/test
  can be scored on clean and on augmented input.

Layout of a corpus folder::

    manifest.json        seed, totals, shards, clip index with split and meta (written last)
    shard_0000.npz ...   concatenated per-frame arrays of its clips + offsets + meta JSON

Per clip (see :func:`load_corpus`): ``audio`` / ``audio_clean`` (T, AUDIO_DIM), ``word_ids``
(T,), ``onsets`` (T,), ``poses`` (T, 27), ``accent`` (T,) (the teacher's
:func:`~model.teacher.accent_strength` of the clean speech, so the teacher can be re-run
without the audio), ``meta`` (dict). Shards are independent and fixed
by (seed, shard index), so the same seed gives the same corpus, interrupted runs resume by
skipping finished shards, and ``--jobs`` builds shards in parallel processes.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import re
import tempfile
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from pathlib import Path

import numpy as np

from core.controls import STYLE_LIMIT, STYLE_NAMES
from core.fileio import atomic_write, atomic_write_text, json_text
from core.npz import load_npz
from core.reading import InputFileError, loads_json, read_bytes
from core.skeleton import FPS, frame_count, mirror_pose
from core.words import TimedWord
from dsl.parser import WORD_RE
from dsl.speech import list_voices, synthesize
from model.features import AUDIO_DIM, SAMPLE_RATE, audio_features, load_audio, word_features
from model.teacher import accent_strength, teach
from model.training import voices as other_voices

FORMAT_VERSION = 2
FORTUNE_DIR = Path("/usr/share/games/fortunes")
#: Mean clip length guess (seconds) used to size shards.
_CLIP_SECONDS = 4.5
SPLITS = ("train", "val", "test")
#: Per-frame arrays of every clip, concatenated in a shard.
ARRAY_KEYS = ("audio", "audio_clean", "word_ids", "onsets", "poses", "accent")
BASE_VOICES = ("en-us", "en-gb", "en-gb-scotland", "en-gb-x-rp", "en-gb-x-gbclan", "en-gb-x-gbcwmd",
               "en-us-nyc", "en-029")
#: Share of the clips spoken by a Festival voice (when Festival and its voices are installed).
FESTIVAL_SHARE = 0.35
#: Share of the clips made of 2-3 sentences with long silent gaps between them; gap lengths (s).
GAP_SHARE = 0.3
GAP_SECONDS = (0.8, 4.0)
VARIANTS = ("", "", "+f1", "+f2", "+f3", "+f4", "+f5", "+m1", "+m2", "+m3", "+m4", "+m5", "+m6", "+m7", "+klatt")


class CorpusError(Exception):
    """A user-facing corpus problem (missing fortunes, bad folder...)."""


# -- sentences ------------------------------------------------------------------------------

_BAD_CHARS = re.compile(r"[{}<>=/\\|_@#$%^&*~`\[\]+]")
_ALLOWED = re.compile(r"[^A-Za-z0-9 .,;:!?'\"()-]")
_SENT_SPLIT = re.compile(r"(?<=[.!?])\s+(?=[A-Z\"'(])")


def _speech_lines(fortune: str) -> str | None:
    lines = []
    for raw in fortune.splitlines():
        line = raw.rstrip()
        s = line.strip()
        if not s:
            continue
        if s.startswith("--") or re.match(r"^[-\u2014]{1,2}\s*[A-Z]", s) and len(lines) > 0 and raw.startswith(("\t", "   ")):
            break  # attribution: the rest is who said it
        if raw.startswith("\t\t") or raw.startswith("        "):
            continue  # indented (poems' attributions, code, tables)
        letters = sum(c.isalpha() for c in s)
        if letters < 0.6 * len(s):
            return None  # ascii art, numbers, code
        lines.append(s)
    if not lines:
        return None
    text = " ".join(lines)
    if _BAD_CHARS.search(text):
        return None
    text = re.sub(r"^\s*[QA]:\s*", "", text)
    text = re.sub(r"\s[QA]:\s", " ", text)
    text = _ALLOWED.sub(" ", text)
    return re.sub(r"\s+", " ", text).strip()


def _chunks(sentence: str, word_re) -> list[str]:
    words = list(word_re.finditer(sentence))
    if len(words) < 3:
        return []
    if len(words) <= 25:
        return [sentence]
    # too long: cut at commas/semicolons, else every ~15 words
    parts = [p.strip() for p in re.split(r"(?<=[,;:])\s+", sentence) if p.strip()]
    out, cur = [], ""
    for p in parts:
        cand = (cur + " " + p).strip()
        if len(list(word_re.finditer(cand))) <= 25:
            cur = cand
        else:
            if cur:
                out.append(cur)
            cur = p
    if cur:
        out.append(cur)
    final = []
    for c in out:
        ws = list(word_re.finditer(c))
        while len(ws) > 25:
            cut = ws[15].start()
            final.append(c[:cut].strip())
            c = c[cut:]
            ws = list(word_re.finditer(c))
        final.append(c.strip())
    return [c for c in final if 3 <= len(list(word_re.finditer(c))) <= 25]


_SENTENCES: dict[tuple, list[str]] = {}


def load_sentences(fortune_dir: Path | str = FORTUNE_DIR) -> list[str]:
    """Sorted, de-duplicated 3-25-word utterances from the fortunes files (cached per folder state)."""
    d = Path(fortune_dir)
    state = tuple(sorted((p.name, p.stat().st_mtime_ns, p.stat().st_size) for p in d.glob("*") if p.is_file())) \
        if d.is_dir() else ()
    key = (str(d.resolve()), state)
    if key not in _SENTENCES:
        _SENTENCES.clear()
        _SENTENCES[key] = _load_sentences(d)
    return list(_SENTENCES[key])


def _load_sentences(fortune_dir: Path) -> list[str]:
    d = Path(fortune_dir)
    files = sorted(p for p in d.glob("*") if p.is_file() and p.suffix not in (".dat", ".u8") and not p.is_symlink()) \
        if d.is_dir() else []
    if not files:
        raise CorpusError(f"no fortunes files in {d}: install them with `apt-get install fortunes fortunes-min`")
    seen, out = set(), []
    for f in files:
        raw = f.read_bytes().decode("utf-8", errors="replace")
        for fortune in re.split(r"^%\s*$", raw, flags=re.M):
            text = _speech_lines(fortune)
            if not text:
                continue
            for sent in _SENT_SPLIT.split(text):
                for chunk in _chunks(sent.strip(" -\"'"), WORD_RE):
                    chunk = re.sub(r"^[A-Z][A-Za-z]*:\s+", "", chunk.strip(" -"))
                    key = re.sub(r"[^a-z0-9 ]", "", chunk.lower())
                    key = re.sub(r"\s+", " ", key).strip()
                    if key and key not in seen and "\ufffd" not in chunk:
                        seen.add(key)
                        out.append(chunk)
    if not out:
        raise CorpusError(f"no usable sentences in the fortunes files of {d}")
    return sorted(out)


def available_voices() -> list[str]:
    """espeak-ng's English voices that are installed, then the Festival ones (``festival:NAME``)."""
    have = set(list_voices())
    return ([v for v in BASE_VOICES if v in have] or ["en-us"]) + other_voices.festival_voices()


# -- audio augmentation ---------------------------------------------------------------------


def _pink(n: int, rng) -> np.ndarray:
    m = 1 << max(1, int(n - 1).bit_length())  # a power of two: fast FFT
    spec = np.fft.rfft(rng.standard_normal(m))
    f = np.arange(len(spec), dtype=np.float64)
    f[0] = 1.0
    y = np.fft.irfft(spec / np.sqrt(f), m)[:n]
    return (y / (np.std(y) + 1e-12)).astype(np.float32)


def augment(y: np.ndarray, sr: int, rng) -> tuple[np.ndarray, dict]:
    """Pitch shift, gain, reverb, band limit and noise (not tempo: see :func:`_tempo`)."""
    import librosa
    from scipy.signal import butter, fftconvolve, sosfilt

    info: dict = {}
    y = np.asarray(y, np.float32)
    if rng.random() < 0.5:
        steps = float(rng.uniform(-1.5, 1.5))
        y = librosa.effects.pitch_shift(y, sr=sr, n_steps=steps).astype(np.float32)
        info["pitch_shift"] = round(steps, 3)
    if rng.random() < 0.3:
        rt60 = float(rng.uniform(0.15, 0.5))
        wet = float(rng.uniform(0.08, 0.3))
        n_ir = int(rt60 * sr)
        t = np.arange(n_ir) / sr
        ir = rng.standard_normal(n_ir) * np.exp(-6.9 * t / rt60)
        ir[0] = 0.0
        ir /= np.sqrt((ir ** 2).sum()) + 1e-9
        y = ((1 - wet) * y + wet * fftconvolve(y, ir)[: len(y)]).astype(np.float32)
        info["reverb"] = {"rt60": round(rt60, 3), "wet": round(wet, 3)}
    if rng.random() < 0.25:
        lo, hi = float(rng.uniform(80, 350)), float(rng.uniform(3200, 7000))
        sos = butter(4, [lo, min(hi, 0.45 * sr)], btype="bandpass", fs=sr, output="sos")
        y = sosfilt(sos, y).astype(np.float32)
        info["band"] = [round(lo), round(hi)]
    if rng.random() < 0.85:
        snr = float(rng.uniform(15, 40))
        kind = "pink" if rng.random() < 0.5 else "white"
        noise = _pink(len(y), rng) if kind == "pink" else rng.standard_normal(len(y)).astype(np.float32)
        p_sig = float(np.mean(y ** 2)) + 1e-12
        noise *= math.sqrt(p_sig / (10 ** (snr / 10)) / (float(np.mean(noise ** 2)) + 1e-12))
        y = y + noise
        info["noise"] = {"kind": kind, "snr_db": round(snr, 1)}
    gain = float(rng.uniform(0.15, 0.95))
    y = (y * gain / (np.max(np.abs(y)) + 1e-9)).astype(np.float32)
    info["peak"] = round(gain, 3)
    return y, info


def _tempo(y: np.ndarray, rate: float) -> np.ndarray:
    import librosa

    return librosa.effects.time_stretch(np.asarray(y, np.float32), rate=rate).astype(np.float32)


# -- one clip -------------------------------------------------------------------------------


def _clip_rng(seed: int, index: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(seed), int(index), int(stream)])


def clip_split(seed: int, index: int) -> str:
    u = _clip_rng(seed, index, 3).random()
    return "train" if u < 0.9 else ("val" if u < 0.95 else "test")


def _draw_style(rng) -> dict[str, float]:
    out = {}
    for k in STYLE_NAMES:
        v = rng.uniform(-STYLE_LIMIT, STYLE_LIMIT) if rng.random() < 0.5 else rng.normal(0, 1.0)
        out[k] = round(float(np.clip(v, -STYLE_LIMIT, STYLE_LIMIT)), 3)
    return out


def _speak(texts: list[str], seed: int, index: int, voices: list[str], cache_dir: Path, rng) -> tuple[np.ndarray, list, dict]:
    """The clip's speech: (audio at SAMPLE_RATE, (word, start, end) list, meta). Several texts are
    joined with silent gaps (digital zeros) between them."""
    espeak = [v for v in voices if not v.startswith(other_voices.PREFIX)]
    festival = [v for v in voices if v.startswith(other_voices.PREFIX)]
    use_festival = bool(festival) and _clip_rng(seed, index, 5).random() < FESTIVAL_SHARE
    pool = festival if use_festival else espeak
    voice = pool[int(rng.integers(len(pool)))] + ("" if use_festival else VARIANTS[int(rng.integers(len(VARIANTS)))])
    rate = int(rng.integers(120, 221))
    pitch = int(rng.integers(30, 71))
    grng = _clip_rng(seed, index, 6)
    meta: dict = {"voice": voice}
    if use_festival:
        meta["engine"] = "festival"
    else:
        meta.update(engine="espeak-ng", rate=rate, pitch=pitch)
    audio, words, pauses, gaps = [], [], [], []
    t0 = 0.0
    for j, text in enumerate(texts):
        if j > 0:
            gap = round(float(grng.uniform(*GAP_SECONDS)), 2)
            gaps.append(gap)
            audio.append(np.zeros(int(gap * SAMPLE_RATE), np.float32))
            t0 += int(gap * SAMPLE_RATE) / SAMPLE_RATE
        if use_festival:
            wav, timed, drawn = other_voices.speak(text, voice, cache_dir, grng)
            meta.setdefault("stretch", []).append(drawn["stretch"])
        else:
            spans = [(m.start(), m.end()) for m in WORD_RE.finditer(text)]
            commas = [m.end() for m in re.finditer(r"[,;:]", text)]
            p = []
            if commas and rng.random() < 0.35:
                p = [(int(commas[int(rng.integers(len(commas)))]), round(float(rng.uniform(0.15, 0.8)), 2))]
            pauses += [[j, *q] for q in p]
            speech = synthesize(text, spans, p, voice=voice, rate=rate, pitch=pitch, cache_dir=cache_dir)
            wav, timed = speech.audio_path, [(w.word, w.start, w.end) for w in speech.words]
        y = load_audio(wav, SAMPLE_RATE)
        audio.append(y)
        words += [(w, a + t0, b + t0) for w, a, b in timed]
        t0 += len(y) / SAMPLE_RATE
    meta["pauses"] = pauses
    meta["gaps"] = gaps
    return np.concatenate(audio), words, meta


def make_clip(text: str | list[str], seed: int, index: int, voices: list[str], cache_dir: Path) -> dict:
    """One corpus clip (arrays + meta), deterministic in (text, seed, index); ``text`` may be a
    list of sentences, spoken with silent gaps between them."""
    rng = _clip_rng(seed, index, 0)
    texts = [text] if isinstance(text, str) else list(text)
    y, words, speech_meta = _speak(texts, seed, index, voices, cache_dir, rng)

    arng = _clip_rng(seed, index, 2)
    tempo = 1.0
    if arng.random() < 0.6:
        tempo = round(float(arng.uniform(0.9, 1.1)), 3)
        y = _tempo(y, tempo)
        words = [(t, a / tempo, b / tempo) for t, a, b in words]
    clean = y
    augmented = arng.random() < 0.8
    aug_info: dict = {"tempo": tempo}
    if augmented:
        y, info = augment(clean, SAMPLE_RATE, arng)
        aug_info.update(info)
    aug_info["augmented"] = augmented

    lead_frames = int(rng.integers(0, int(0.6 * FPS) + 1))
    tail = float(rng.uniform(0.3, 1.0))
    lead = lead_frames / FPS
    n = frame_count(lead + len(y) / SAMPLE_RATE + tail)
    mwords = [TimedWord(t, round(a + lead, 4), round(b + lead, 4)) for t, a, b in words]

    style = _draw_style(rng)
    mirror = bool(rng.random() < 0.5)
    accent = accent_strength(clean, n, lead)
    poses = teach(mwords, n, strength=accent, style=style, rng=_clip_rng(seed, index, 1))
    if mirror:
        poses = mirror_pose(poses)
    eff_style = dict(style)
    if mirror:
        eff_style["handedness"] = -eff_style["handedness"]
    ids, onsets = word_features(mwords, n)
    return {
        "audio": audio_features(y, n, lead_frames).astype(np.float16),
        "audio_clean": audio_features(clean, n, lead_frames).astype(np.float16),
        "word_ids": ids.astype(np.int32),
        "onsets": onsets.astype(np.float32),
        "poses": np.asarray(poses, np.float32),
        "accent": accent.astype(np.float16),
        "meta": {
            "index": index, "text": " ".join(texts), **speech_meta, "lead_in": round(lead, 4), "n_frames": n,
            "style": eff_style, "teacher_style": style, "mirror": mirror,
            "augmentation": aug_info, "words": [w.to_dict(4) for w in mwords], "split": clip_split(seed, index),
        },
    }


# -- shards ---------------------------------------------------------------------------------


def _config(seed: int, clips_per_shard: int, n_sentences: int, sentences_hash: str) -> dict:
    return {"version": FORMAT_VERSION, "seed": int(seed), "clips_per_shard": int(clips_per_shard),
            "sentences": n_sentences, "sentences_hash": sentences_hash}


def shard_path(out: Path, k: int) -> Path:
    return Path(out) / f"shard_{k:04d}.npz"


def _order(seed: int, n: int) -> np.ndarray:
    return np.random.default_rng([int(seed), 7]).permutation(n)


def build_shard(out: str, k: int, config: dict, sentences: list[str], voices: list[str]) -> dict:
    """Make shard ``k`` and write it atomically; returns its summary."""
    cps = config["clips_per_shard"]
    order = _order(config["seed"], len(sentences))
    clips = []
    with tempfile.TemporaryDirectory(prefix="sgt-corpus-") as tmp:
        for j in range(cps):
            index = k * cps + j
            texts = [sentences[int(order[index % len(order)])]]
            grng = _clip_rng(config["seed"], index, 4)
            if grng.random() < GAP_SHARE:
                texts += [sentences[int(grng.integers(len(sentences)))] for _ in range(int(grng.integers(1, 3)))]
            clips.append(make_clip(texts, config["seed"], index, voices, Path(tmp)))
    offsets = np.cumsum([0] + [len(c["poses"]) for c in clips]).astype(np.int64)
    arrays = {key: np.concatenate([c[key] for c in clips]) for key in ARRAY_KEYS}
    metas = [c["meta"] for c in clips]
    buf = io.BytesIO()  # np.savez stamps every entry 1980-01-01: the same arrays give the same bytes
    np.savez(buf, offsets=offsets, meta=np.array(json.dumps(metas)), config=np.array(json.dumps(config, sort_keys=True)),
             **arrays)
    atomic_write(shard_path(Path(out), k), buf.getvalue())
    return {"k": k, "frames": int(offsets[-1]), "metas": metas}


#: What reading a damaged or foreign shard file raises (core.npz's NpzError is a ValueError;
#: json; a missing array); such a shard is built again.
_DAMAGED_SHARD = (OSError, ValueError, LookupError)


def _read_shard_summary(path: Path, config: dict) -> dict | None:
    """The summary of a finished shard built with ``config``; None when the shard is missing,
    damaged or made with other settings (it is then built again)."""
    if not path.is_file():
        return None
    try:
        z = load_npz(path, "corpus shard", keys={"config", "offsets", "meta"})
        if loads_json(str(z["config"])) != json.loads(json.dumps(config, sort_keys=True)):
            return None
        return {"frames": int(z["offsets"][-1]), "metas": loads_json(str(z["meta"]))}
    except _DAMAGED_SHARD:
        return None


def _read_shard(root: Path, name) -> dict[str, np.ndarray]:
    """The arrays of shard file ``name`` (a plain file name in the corpus folder ``root``), read
    by :func:`core.npz.load_npz`, every float value checked to be a finite number:
    :class:`CorpusError` naming the shard otherwise."""
    if not isinstance(name, str) or Path(name).name != name or name in ("", ".", ".."):
        raise CorpusError(f"the manifest of {root} names the shard {name!r}; shards are files in the corpus folder")
    path = root / name
    try:
        arrays = load_npz(path, "corpus shard", keys={"offsets", *ARRAY_KEYS})  # format 1 has no accent
    except InputFileError as exc:
        raise CorpusError(f"{path}: {exc.reason}") from None
    except (OSError, ValueError) as exc:  # missing, NpzError
        raise CorpusError(f"cannot read the corpus shard {path}: {exc}; build the corpus again with "
                          f"`sgt corpus -o {root}`") from None
    for key, arr in arrays.items():
        if arr.dtype.kind == "f" and not np.isfinite(arr).all():
            frame = int(np.argwhere(~np.isfinite(arr))[0][0])
            raise CorpusError(f"{path}: {key} at frame {frame} is not a finite number; build the corpus "
                              f"again with `sgt corpus -o {root}`")
    missing = [k for k in ("offsets", *ARRAY_KEYS[:-1]) if k not in arrays]
    if missing:
        raise CorpusError(f"{path} has no {', '.join(missing)}: build the corpus again with `sgt corpus -o {root}`")
    return arrays


class _InlineExecutor(Executor):
    """Runs each task when it is submitted: ``--jobs 1`` through the same scheduler, no process."""

    def submit(self, fn, /, *args, **kwargs):
        future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # handed to the caller by future.result(), as a process pool does
            future.set_exception(exc)
        return future


def _executor(jobs: int) -> Executor:
    if jobs <= 1:
        return _InlineExecutor()
    import multiprocessing as mp

    return ProcessPoolExecutor(max_workers=jobs, mp_context=mp.get_context("spawn"))


def _complete_prefix(done: dict[int, dict], target: int) -> int | None:
    """The last shard of the shortest run 0, 1, ..., k of finished shards holding ``target``
    frames, or None while there is no such run."""
    total = 0
    k = 0
    while k in done:
        total += done[k]["frames"]
        if total >= target:
            return k
        k += 1
    return None


def _enough_in_flight(done: dict[int, dict], pending: dict, target: int) -> bool:
    """Whether the shards being built will probably reach ``target`` (at the mean shard size so far)."""
    if not pending or not done:
        return False
    known = sum(d["frames"] for d in done.values())
    return known + len(pending) * known / len(done) >= target


def _build_shards(out: Path, config: dict, sentences: list[str], voices: list[str], target: int, jobs: int,
                  progress=None) -> tuple[list[dict], int]:
    """Shards 0, 1, ... until they hold ``target`` frames, ``jobs`` at a time; a shard finished by
    an earlier run with the same settings is kept. Returns (their summaries, how many were kept)."""
    done: dict[int, dict] = {}
    kept = 0

    def report(what: str) -> None:
        if progress:
            progress(min(sum(d["frames"] for d in done.values()), target), target, what)

    pending: dict[Future, int] = {}
    next_k = 0
    pool = _executor(jobs)
    try:
        while _complete_prefix(done, target) is None:
            while len(pending) < max(1, jobs) and not _enough_in_flight(done, pending, target):
                k, next_k = next_k, next_k + 1
                summary = _read_shard_summary(shard_path(out, k), config)
                if summary is None:
                    pending[pool.submit(build_shard, str(out), k, config, sentences, voices)] = k
                    continue
                done[k] = summary
                kept += 1
                report(f"shard {k} (kept)")
                if _complete_prefix(done, target) is not None:
                    break
            if not pending or _complete_prefix(done, target) is not None:
                continue
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in finished:
                k = pending.pop(future)
                done[k] = future.result()
                report(f"shard {k}")
    finally:
        for future in pending:
            future.cancel()
        pool.shutdown(wait=True, cancel_futures=True)
    last = _complete_prefix(done, target)
    return [done[k] for k in range(last + 1)], kept


def _manifest(out: Path, shards: list[dict], *, hours: float, seed: int, config: dict, n_sentences: int,
              voices: list[str]) -> dict:
    clips, files = [], []
    for k, shard in enumerate(shards):
        name = shard_path(out, k).name
        offset = 0
        for j, m in enumerate(shard["metas"]):
            clips.append({"id": f"{k:04d}_{j:03d}", "shard": name, "position": j, "frame_offset": offset, **m})
            offset += m["n_frames"]
        files.append({"file": name, "clips": len(shard["metas"]), "frames": shard["frames"]})
    total = sum(shard["frames"] for shard in shards)
    return {
        "format": "sgt-corpus", "version": FORMAT_VERSION, "seed": int(seed), "hours_requested": hours,
        "fps": FPS, "audio_dim": AUDIO_DIM, "clips_per_shard": config["clips_per_shard"],
        "total_frames": int(total), "total_hours": round(total / FPS / 3600, 4),
        "sentences": n_sentences, "voices": voices,
        "split_counts": {s: sum(c["split"] == s for c in clips) for s in SPLITS},
        "config": config, "shards": files, "clips": clips,
        "audio_note": "audio: features of the augmented speech; audio_clean: the same speech (same tempo) unaugmented",
    }


def build_corpus(out, *, hours: float = 2.0, seed: int = 0, jobs: int = 1, clips_per_shard: int | None = None,
                 fortune_dir: Path | str = FORTUNE_DIR, progress=None, log=None) -> dict:
    """Build (or resume) a corpus of at least ``hours`` of motion in ``out``; returns the manifest.

    The result depends on the seed, the sentences, the voices and ``clips_per_shard`` only, not
    on ``jobs`` (shard k is fixed by them, see :func:`build_shard`)."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise CorpusError(f"{out} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    if hours <= 0:
        raise CorpusError("--hours must be positive")
    sentences = load_sentences(fortune_dir)
    voices = available_voices()
    if clips_per_shard is None:
        clips_per_shard = int(min(128, max(8, round(hours * 3600 / _CLIP_SECONDS / 16))))
    shash = hashlib.sha256("\n".join(sentences).encode()).hexdigest()[:16]
    config = _config(seed, clips_per_shard, len(sentences), shash)
    target = int(math.ceil(hours * 3600 * FPS))
    shards, kept = _build_shards(out, config, sentences, voices, target, jobs, progress)
    manifest = _manifest(out, shards, hours=hours, seed=seed, config=config, n_sentences=len(sentences), voices=voices)
    atomic_write_text(out / "manifest.json", json_text(manifest, indent=1) + "\n")
    if log:
        total = manifest["total_frames"]
        log(f"{len(manifest['clips'])} clips, {total} frames ({total / FPS / 3600:.2f} h) in {len(shards)} shards"
            f" ({kept} kept from an earlier run) -> {out}")
    return manifest


# -- loading --------------------------------------------------------------------------------


def load_manifest(path) -> dict:
    """The corpus's ``manifest.json``, read by :func:`core.reading.read_bytes` (a regular file of
    at most ``LIMITS["corpus manifest"]``); :class:`CorpusError` for anything else."""
    p = Path(path)
    mp = p / "manifest.json" if p.is_dir() else p
    try:
        m = loads_json(read_bytes(mp, "corpus manifest"))
    except FileNotFoundError:
        raise CorpusError(f"no corpus manifest at {mp} (build one with `sgt corpus -o {p}`)") from None
    except InputFileError as exc:
        raise CorpusError(f"{mp}: {exc.reason}") from None
    except OSError as exc:
        raise CorpusError(f"cannot read {mp}: {exc.strerror or exc}") from None
    except ValueError as exc:  # JSON, UTF-8, nesting
        raise CorpusError(f"{mp} is not valid JSON: {exc}") from None
    if not isinstance(m, dict) or m.get("format") != "sgt-corpus":
        raise CorpusError(f"{mp} is not an sgt corpus manifest")
    return m


def load_corpus(path, split: str | None = "train", *, dtype=np.float32) -> list[dict]:
    """Clips of ``split`` ("train", "val", "test", or None for all) as dicts of arrays + ``meta``.

    Keys: ``audio``, ``audio_clean`` (T, AUDIO_DIM), ``word_ids`` (T,) int64, ``onsets`` (T,),
    ``poses`` (T, 27), ``accent`` (T,), ``meta`` (text, voice, style, words, ...), ``id``, ``split``.
    """
    if split is not None and split not in SPLITS:
        raise CorpusError(f"unknown split {split!r}: choose one of {', '.join(SPLITS)}")
    root = Path(path)
    m = load_manifest(root)
    root = root if root.is_dir() else root.parent
    try:
        return _load_clips(root, m, split, dtype)
    except (KeyError, TypeError, IndexError) as exc:  # a manifest or shard whose entries are not what sgt corpus writes
        raise CorpusError(f"the corpus at {root} is malformed ({exc.__class__.__name__}: {exc}): "
                          f"build it again with `sgt corpus -o {root}`") from None


def _load_clips(root: Path, m: dict, split: str | None, dtype) -> list[dict]:
    want: dict[str, list[dict]] = {}
    for c in m["clips"]:
        if split is None or c["split"] == split:
            want.setdefault(c["shard"], []).append(c)
    out = []
    for shard in m["shards"]:
        entries = want.get(shard["file"])
        if not entries:
            continue
        arrays = _read_shard(root, shard["file"])
        offsets = arrays["offsets"]
        for c in entries:
            a, b = int(offsets[c["position"]]), int(offsets[c["position"] + 1])
            if not 0 <= a <= b <= len(arrays["poses"]):
                raise CorpusError(f"{root / shard['file']}: clip {c['id']!r} spans frames {a} to {b} of "
                                  f"{len(arrays['poses'])}: build the corpus again with `sgt corpus -o {root}`")
            out.append({
                "id": c["id"], "split": c["split"],
                "audio": arrays["audio"][a:b].astype(dtype),
                "audio_clean": arrays["audio_clean"][a:b].astype(dtype),
                "word_ids": arrays["word_ids"][a:b].astype(np.int64),
                "onsets": arrays["onsets"][a:b].astype(dtype),
                "poses": arrays["poses"][a:b].astype(np.float32),
                **({"accent": arrays["accent"][a:b].astype(np.float32)} if "accent" in arrays else {}),
                "meta": {k: v for k, v in c.items() if k not in ("shard", "position", "frame_offset")},
            })
    return out
