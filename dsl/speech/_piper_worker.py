"""The piper worker: a process that holds one neural voice (an ONNX model run by onnxruntime)
and answers synthesis requests, one a line (this file run as a script with ``--serve``, by
:mod:`dsl.speech.piper`; it imports nothing of sgt).

Text from a script reaches piper's own espeak-ng phonemizer (a C library) here, never in the
process that asked, as :mod:`dsl.speech._espeak` keeps espeak-ng's synthesis out of it.

Determinism: the VITS model draws Gaussian noise twice per synthesis (the duration
predictor's and the prior's, ``RandomNormalLike`` nodes) from a generator that onnxruntime
seeds from the clock and advances with every run. The model is changed in memory so that
both noises are inputs instead (a ``Slice`` of the input to the shape the node would have
drawn), filled from numpy's generator seeded with the request's seed and the sentence's
phoneme ids: the same text gives the same samples, in any process, with the model's own
noise scales (the voice's natural variation kept). The frames' noise is drawn frame by
frame (each frame's 256 values in a row), so a longer draw starts with the shorter one: when
the sentence needs more frames than were drawn, the run is made again with twice as many and
gives what one right-sized draw would have. onnxruntime runs on one thread (the same sums in
the same order on every machine).

Alignments: the model's ``Ceil`` node (frames per phoneme id, as piper's
``patch_voice_with_alignment`` finds it) is made an output; a frame is ``hop_length`` (256)
samples at the voice's rate (22,050 Hz for joe). Each phoneme owns its ids and the padding
id after it, so the counts of a sentence add up to its samples exactly.

Answer: a JSON header line ``{"ok": true, "sample_rate", "nbytes", "tokens": [[phoneme,
samples], ...], "words": [[phoneme, ...], ...]}`` (the sentences' tokens in order, each
sentence between ``^`` and ``$``; the phonemes of each of the request's ``words`` read on its
own), then the audio as signed 16-bit little-endian samples; ``{"ok": false, "kind", "message"}``
on failure.
"""

from __future__ import annotations

import json
import sys
import zlib

#: Channels of noise drawn per frame (the model slices what it needs: 192 for joe's prior, 2
#: for the duration predictor).
NOISE_CHANNELS = 256
#: The frames' noise first drawn, per phoneme id and unit of length scale (joe needs about 3).
FRAMES_PER_ID = 6
#: Peak of the result, of full scale (the model's output is scaled to it, the whole utterance at once).
PEAK = 0.9


class _Voice:
    def __init__(self, package: str) -> None:
        import importlib

        import numpy as np
        import onnx
        import onnxruntime
        from piper import PiperVoice
        from piper.config import PiperConfig
        from piper.patch_voice_with_alignment import add_alignment_output

        pkg = importlib.import_module(package)
        model = onnx.load(str(pkg.model_path()))
        add_alignment_output(model)
        self.noise_inputs = _noise_inputs(model)
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        options.log_severity_level = 3
        session = onnxruntime.InferenceSession(model.SerializeToString(), options, providers=["CPUExecutionProvider"])
        with open(pkg.config_path(), encoding="utf-8") as f:
            config = PiperConfig.from_dict(json.load(f))
        self.np = np
        self.voice = PiperVoice(session=session, config=config)
        self.config = config

    def synth(self, text: str, length_scale: float, seed: int) -> tuple[bytes, list[list]]:
        np = self.np
        id_map = self.config.phoneme_id_map
        pad = list(id_map["_"])
        tokens: list[list] = []
        chunks = []
        for sentence in self.voice.phonemize(text):
            names = ["^"] + [p for p in sentence if p in id_map and p not in "^$_"] + ["$"]
            if len(names) == 2:
                continue
            ids: list[int] = []
            owner: list[int] = []
            for k, name in enumerate(names):
                add = list(id_map[name]) + (pad if name != "$" else [])
                ids += add
                owner += [k] * len(add)
            audio, frames = self._run(ids, length_scale, seed)
            counts = np.bincount(np.asarray(owner), weights=frames, minlength=len(names)) * self.config.hop_length
            tokens += [[name, round(float(c))] for name, c in zip(names, counts)]
            chunks.append(audio[: int(frames.sum()) * self.config.hop_length])
        if not chunks:
            return b"", []
        audio = np.concatenate(chunks)
        peak = float(np.max(np.abs(audio))) if len(audio) else 0.0
        scale = PEAK * 32767.0 / peak if peak > 1e-8 else 0.0
        return np.clip(np.round(audio * scale), -32767, 32767).astype("<i2").tobytes(), tokens

    def _run(self, ids: list[int], length_scale: float, seed: int):
        np = self.np
        cfg = self.config
        base = np.random.SeedSequence([seed, zlib.crc32(np.asarray(ids, dtype="<i8").tobytes())])
        dp_seed, z_seed = base.spawn(2)
        dp_noise = np.random.default_rng(dp_seed).standard_normal((len(ids), NOISE_CHANNELS), dtype=np.float32)
        frames = max(64, int(len(ids) * FRAMES_PER_ID * length_scale))
        args = {"input": np.asarray([ids], dtype=np.int64), "input_lengths": np.asarray([len(ids)], dtype=np.int64),
                "scales": np.asarray([cfg.noise_scale, length_scale, cfg.noise_w_scale], dtype=np.float32)}
        while True:
            z_noise = np.random.default_rng(z_seed).standard_normal((frames, NOISE_CHANNELS), dtype=np.float32)
            for name, noise in zip(self.noise_inputs, (dp_noise, z_noise)):
                args[name] = np.ascontiguousarray(noise.T[None])
            try:
                audio, widths = self.voice.session.run(None, args)
            except Exception:  # onnxruntime's errors have no common base: the frames' noise was short?
                if frames > len(ids) * 400:
                    raise
                frames *= 2
                continue
            return audio.reshape(-1), np.asarray(widths, dtype=np.float64).reshape(-1)


def _noise_inputs(model) -> list[str]:
    """Replace the model's ``RandomNormalLike`` nodes by slices of new float inputs of shape
    (1, :data:`NOISE_CHANNELS`, length); their names, the duration predictor's (whose node is
    under ``/dp/``) first."""
    from onnx import TensorProto, helper

    graph = model.graph
    found = [n for n in graph.node if n.op_type == "RandomNormalLike"]
    if len(found) != 2 or sum("/dp/" in n.name for n in found) != 1:
        raise ValueError(f"the voice model has {len(found)} noise nodes where 2 were expected (one under /dp/)")
    found.sort(key=lambda n: "/dp/" not in n.name)
    names = []
    for k, node in enumerate(found):
        name = f"sgt_noise_{k}"
        names.append(name)
        graph.input.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, [1, NOISE_CHANNELS, None]))
        shape, zeros = f"{name}_shape", f"{name}_starts"
        replacement = [
            helper.make_node("Shape", [node.input[0]], [shape]),
            helper.make_node("Constant", [], [zeros], value=helper.make_tensor(zeros, TensorProto.INT64, [3], [0, 0, 0])),
            helper.make_node("Slice", [name, zeros, shape], list(node.output)),
        ]
        at = list(graph.node).index(node)
        graph.node.remove(node)
        for j, new in enumerate(replacement):
            graph.node.insert(at + j, new)
    return names


def _answer(voices: dict, line: bytes) -> bytes:
    try:
        req = json.loads(line.decode("utf-8"))
        package = str(req["package"])
        if package not in voices:
            voices[package] = _Voice(package)
        voice = voices[package]
        raw, tokens = voice.synth(str(req["text"]), float(req["length_scale"]), int(req["seed"]))
        words = [[p for sentence in voice.voice.phonemize(str(w)) for p in sentence] for w in req.get("words", [])]
        header = {"ok": True, "sample_rate": voice.config.sample_rate, "nbytes": len(raw), "tokens": tokens,
                  "words": words}
    except ImportError as e:
        raw, header = b"", {"ok": False, "kind": "missing", "message": f"{e.name or e} is not installed", "nbytes": 0}
    except Exception as e:  # the worker answers every request: piper's and onnxruntime's errors included
        raw, header = b"", {"ok": False, "kind": "synth", "message": f"{type(e).__name__}: {e}"[:500], "nbytes": 0}
    return json.dumps(header).encode("utf-8") + b"\n" + raw


def _serve_main() -> int:
    """One request per input line, answered in order; ends when the input closes."""
    voices: dict = {}
    out = sys.stdout.buffer
    for line in sys.stdin.buffer:
        out.write(_answer(voices, line))
        out.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(_serve_main())
