"""Training the flow engine's network (:mod:`model.flow_net`) on CPU: conditional flow matching,
then few-step distillation.

Each step draws windows of the training clips (:class:`model.training.train.Windows`), simulates
controls from their references as the regressor's training does
(:func:`~model.training.train.simulate_controls`: pose-control spans, seed poses at the start,
the reference's style with an element dropped, everything dropped on a share of the windows,
which is also what classifier-free guidance on the style needs), draws noise and flow times
(logit-normal), and minimises :meth:`model.flow_net.FlowNet.loss`. The weights' exponential
moving average (``cfg.ema``) is what is validated and shipped.

A flow sampled in a few Euler steps is blurrier than in many. With ``cfg.teacher`` (trained flow
weights) the run distils instead (:meth:`model.flow_net.FlowNet.distill_loss`): the student
starts as the teacher and learns, for each of its few sampler steps (``cfg.net["times"]``), to land
where the teacher lands in ``cfg.substeps`` steps, on the same windows, controls and noise.

Every epoch ends with a checkpoint (``checkpoint.pt``, written atomically: the network, its
average, the optimiser and the random stream, all readable with ``torch.load(...,
weights_only=True)``) and a row of ``metrics.jsonl``; the same call resumes from the checkpoint
and ends on the same weights as a run that was never stopped. Validation samples 192 fixed
windows of the val split with fixed noise: FGD of the free samples against their references
(the shipped extractor), the Hellinger distance of their pooled joint-speed histograms, the
SCS of samples given the references' style, and the flow loss at fixed times. ``flow.pt``
keeps the epoch with the lowest validation FGD, ``last.pt`` the last epoch.
"""

from __future__ import annotations

import copy
import io
import json
import math
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from core.fileio import atomic_write
from core.skeleton import POSE_DIM
from model.style import style as style_of
from model.training import metrics
from model.training.train import Windows, _checkpoint_difference, learning_rate, simulate_controls
from model.training.train_config import FlowConfig
from model.weights import save_weights

#: Validation windows (drawn once from the val split with a fixed seed, as the regressor's).
VAL_WINDOWS = 192


def pose_statistics(clips) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation (27,) of every pose number over the clips' frames."""
    poses = np.concatenate([np.asarray(c["poses"], np.float64) for c in clips])
    return poses.mean(axis=0), poses.std(axis=0)


def flow_times(rng: np.random.Generator, n: int, cfg) -> np.ndarray:
    """``n`` flow times: logit-normal (``cfg.t_mean``, ``cfg.t_std``), a share ``cfg.t_uniform``
    of them uniform in [0, 1) instead; at most :data:`~model.flow_net.T_MAX`."""
    from model.flow_net import T_MAX  # lazy: torch

    t = 1.0 / (1.0 + np.exp(-(cfg.t_mean + cfg.t_std * rng.standard_normal(n))))
    t = np.where(rng.random(n) < cfg.t_uniform, rng.random(n), t)
    return np.minimum(t, T_MAX).astype(np.float32)


def _tensors(batch: dict, torch, device):
    return (torch.as_tensor(batch["audio"], dtype=torch.float32, device=device),
            torch.as_tensor(batch["word_ids"], dtype=torch.long, device=device),
            torch.as_tensor(batch["onsets"], dtype=torch.float32, device=device),
            torch.as_tensor(batch["poses"], dtype=torch.float32, device=device))


class Validation:
    """The fixed validation windows, noise and flow times, and the figures of one network on them."""

    def __init__(self, val_clips, window: int, extractor="default") -> None:
        from model.training import fgd  # lazy: torch

        self.batch = Windows(val_clips, window).fixed(VAL_WINDOWS)
        rng = np.random.default_rng(4321)
        n, t = self.batch["poses"].shape[:2]
        self.z = rng.standard_normal((n, t, POSE_DIM)).astype(np.float32)
        self.t = np.linspace(0.02, 0.98, n, dtype=np.float32)
        self.extractor = fgd.load() if extractor == "default" else extractor
        self.reference = self.extractor.features(list(self.batch["poses"])) if self.extractor is not None else None

    def figures(self, model, device="cpu") -> dict:
        import torch

        audio, ids, onsets, ref = _tensors(self.batch, torch, device)
        b, t, _ = ref.shape
        z = torch.as_tensor(self.z, device=device)
        zeros_p = torch.zeros_like(ref)
        zeros_m = torch.zeros(b, t, device=device)
        zeros_s = torch.zeros(b, t, 3, device=device)
        with torch.no_grad():
            ref_style = style_of(ref)
            free = model(audio, ids, onsets, zeros_p, zeros_m, zeros_s, zeros_s, z)
            styled = model(audio, ids, onsets, zeros_p, zeros_m, ref_style, torch.ones_like(ref_style), z)
            loss = model.loss(audio, ids, onsets, zeros_p, zeros_m, zeros_s, zeros_s, ref, z,
                              torch.as_tensor(self.t, device=device))
        samples = list(free.cpu().numpy())
        refs = list(self.batch["poses"])
        row = {"val_loss": float(loss),
               "val_hellinger": metrics.hellinger(metrics.speed_histogram(refs), metrics.speed_histogram(samples)),
               "val_scs": float((style_of(styled) - ref_style).abs().mean())}
        if self.extractor is not None:
            row["val_fgd"] = metrics.fgd(self.reference, self.extractor.features(samples))
        return row


def _score(row: dict) -> float:
    """Which epoch's weights :func:`train_flow` keeps as ``flow.pt``: the lowest validation FGD
    (the flow loss where no extractor is given)."""
    return row.get("val_fgd", row["val_loss"])


def train_flow(train_clips, val_clips, out_dir: Path, cfg: FlowConfig, *, resume: bool = True, progress=None,
               log=print, extractor="default"):
    """Train (or resume) the flow network and return its moving average. Writes in ``out_dir``:
    checkpoint.pt (to resume), metrics.jsonl (a row per epoch), last.pt (the last epoch's
    averaged weights) and flow.pt (the epoch with the best :func:`_score`). A checkpoint made
    with other settings is refused (ValueError naming them), never overwritten.
    ``extractor``: the FGD extractor of the validation ("default": the shipped one; None: no FGD)."""
    import torch

    from model.flow_net import FlowNet  # lazy: torch

    torch.set_num_threads(max(1, cfg.threads))
    torch.manual_seed(cfg.seed)
    dev = torch.device("cuda" if cfg.device == "auto" and torch.cuda.is_available() else "cpu")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    ckpt_path = out_dir / "checkpoint.pt"
    metrics_path = out_dir / "metrics.jsonl"

    data = Windows(train_clips, cfg.window)
    validation = Validation(val_clips, cfg.window, extractor)
    teacher = None
    if cfg.teacher is not None:  # distillation: the student starts as the teacher, with its own sampler steps
        from model.weights import load_weights  # lazy: torch

        teacher = load_weights(cfg.teacher, "flow")[0].to(dev)
        for p in teacher.parameters():
            p.requires_grad_(False)
        model = FlowNet({**teacher.config, **cfg.net})
        model.load_state_dict(teacher.state_dict())
    else:
        model = FlowNet(cfg.net)
        model.set_pose_statistics(*pose_statistics(data.clips))
    model.to(dev)
    ema = copy.deepcopy(model).eval()
    for p in ema.parameters():
        p.requires_grad_(False)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    rng = np.random.default_rng(cfg.seed)
    epoch0, best = 0, math.inf
    config = asdict(cfg)
    if resume and ckpt_path.exists():
        state = torch.load(str(ckpt_path), map_location="cpu", weights_only=True)
        # settings added since the checkpoint was made: it was made with their defaults
        state["config"] = {**asdict(FlowConfig()), **state.get("config", {})}
        if state["config"] | {"minutes": cfg.minutes} != config or len(state.get("rngs", [])) != 1:
            raise ValueError(f"{ckpt_path} was made with {_checkpoint_difference(state, config, 1)}; give the settings "
                             "it was made with to resume it, or start afresh with --fresh (which replaces it), or train "
                             "into another folder")
        model.load_state_dict(state["model"])
        ema.load_state_dict(state["ema"])
        opt.load_state_dict(state["opt"])
        rng.bit_generator.state = state["rngs"][0]
        epoch0, best = int(state["epoch"]), float(state["best"])
        log(f"resumed from {ckpt_path} after epoch {epoch0}")
    started = time.monotonic()
    total_steps = cfg.epochs * cfg.steps_per_epoch
    for epoch in range(epoch0, cfg.epochs):
        model.train()
        loss_sum = 0.0
        for step in range(cfg.steps_per_epoch):
            done = epoch * cfg.steps_per_epoch + step
            for group in opt.param_groups:
                group["lr"] = learning_rate(cfg, done)
            batch = data.sample(rng, cfg.batch)
            audio, ids, onsets, ref = _tensors(batch, torch, dev)
            with torch.no_grad():
                ref_style = style_of(ref)
            pose, pmask, sty, smask = simulate_controls(batch["poses"], ref_style.cpu().numpy(), rng, cfg)
            z = torch.as_tensor(rng.standard_normal(ref.shape), dtype=torch.float32, device=dev)
            controls = (torch.as_tensor(pose, device=dev), torch.as_tensor(pmask, device=dev),
                        torch.as_tensor(sty, device=dev), torch.as_tensor(smask, device=dev))
            if teacher is not None:
                loss = model.distill_loss(teacher, audio, ids, onsets, *controls, z, cfg.substeps)
            else:
                t = torch.as_tensor(flow_times(rng, len(ref), cfg), device=dev)
                loss = model.loss(audio, ids, onsets, *controls, ref, z, t)
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            with torch.no_grad():
                for avg, cur in zip(ema.parameters(), model.parameters()):
                    avg.lerp_(cur, 1.0 - cfg.ema)
            loss_sum += loss.item()
            if progress:
                progress(done + 1, total_steps, f"epoch {epoch + 1} loss {loss.item():.3f}")
        row = {"epoch": epoch + 1, "loss": loss_sum / cfg.steps_per_epoch, **validation.figures(ema, dev)}
        row["score"] = _score(row)
        row["best"] = row["score"] < best
        row["minutes"] = (time.monotonic() - started) / 60
        best = min(best, row["score"])
        with open(metrics_path, "a", encoding="utf-8") as f:
            f.write(json.dumps(row) + "\n")
        log(" ".join(f"{k}={v:.4f}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()))
        meta = {"train_config": config, "epochs_done": epoch + 1, "validation": row}
        save_weights(out_dir / "last.pt", ema, meta=meta)
        if row["best"]:
            save_weights(out_dir / "flow.pt", ema, meta=meta)
        buf = io.BytesIO()
        torch.save({"model": model.state_dict(), "ema": ema.state_dict(), "opt": opt.state_dict(),
                    "rngs": [rng.bit_generator.state], "epoch": epoch + 1, "config": config, "best": best}, buf)
        atomic_write(ckpt_path, buf.getvalue())
        if cfg.minutes is not None and (time.monotonic() - started) / 60 >= cfg.minutes:
            log(f"time budget of {cfg.minutes} min reached after epoch {epoch + 1}")
            break
    return ema
