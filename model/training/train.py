"""Training the controllable generator (SGToolkit section 5) on CPU.

Objective (Eq. 7): ``alpha * Huber(p, p_hat) + beta * GAN(p_hat) + gamma * L1(style(p), style(p_hat))``,
with the adversarial term switchable (``beta = 0``), plus two terms the paper does not have
(both switchable, see docs/model.md): ``ctrl * L1`` over the pose-controlled frames only (the
paper names imperfect pose following as its main limitation; a 5-frame control is a tiny
share of the plain Huber term) and ``vel * L1`` between frame-to-frame velocities (against the
jitter a per-frame loss leaves). Controls are simulated from the reference
motion as in the paper: a pose-control span of random length 1..T at a random place, seed poses
at the start of the window (what sliding-window generation feeds), style controls computed from
the reference with one element dropped at random, and all controls dropped at random so the
model also works as a fully automatic generator.

Checkpoints (``checkpoint.pt``) are written atomically after every epoch and training resumes
from them; per-epoch metrics go to ``metrics.jsonl``; validation uses a held-out split.
"""

from __future__ import annotations

import io
import json
import math
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from core.controls import STYLE_NAMES
from core.fileio import atomic_write
from core.reading import InputFileError, read_bytes
from model.style import style as style_of
from model.training.metrics import pcs_frames
from model.training.speed_hist import soft_speed_hellinger
from model.training.takes import record_takes
from model.training.train_config import WINDOW, TrainConfig  # noqa: F401  (re-exported)
from model.weights import not_torch_archive, save_weights

# -- data -------------------------------------------------------------------------------------


class Windows:
    """Random training windows drawn from a list of clips (dicts of per-frame arrays)."""

    KEYS = ("audio", "word_ids", "onsets", "poses")

    def __init__(self, clips: list[dict], window: int) -> None:
        self.clips = [c for c in clips if len(c["poses"]) >= window]
        if not self.clips:
            raise ValueError(f"no clip is at least {window} frames long")
        self.window = window
        lengths = np.array([len(c["poses"]) - window + 1 for c in self.clips], np.float64)
        self.p = lengths / lengths.sum()

    def sample(self, rng: np.random.Generator, batch: int, clean_fraction: float = 0.3) -> dict[str, np.ndarray]:
        """A batch of windows; ``clean_fraction`` of them use the un-augmented audio when the clip has it."""
        picks = rng.choice(len(self.clips), size=batch, p=self.p)
        out = {k: [] for k in self.KEYS}
        for i in picks:
            c = self.clips[i]
            s = int(rng.integers(0, len(c["poses"]) - self.window + 1))
            for k in self.KEYS:
                src = c["audio_clean"] if k == "audio" and "audio_clean" in c and rng.random() < clean_fraction else c[k]
                out[k].append(np.asarray(src[s : s + self.window]))
        return {k: np.stack(v) for k, v in out.items()}

    def fixed(self, count: int, seed: int = 1234) -> dict[str, np.ndarray]:
        return self.sample(np.random.default_rng(seed), count, clean_fraction=0.0)


def simulate_controls(poses: np.ndarray, ref_style: np.ndarray, rng: np.random.Generator, cfg: TrainConfig):
    """Pose controls (B,T,27), pose mask (B,T), style (B,T,3), style mask (B,T,3) from the reference."""
    b, t, _ = poses.shape
    pose = np.zeros_like(poses)
    pmask = np.zeros((b, t), np.float32)
    style = np.zeros_like(ref_style)
    smask = np.zeros_like(ref_style)
    for i in range(b):
        if rng.random() < cfg.p_drop_all:
            continue
        if rng.random() < cfg.p_pose:
            length = int(rng.integers(1, t + 1))
            start = int(rng.integers(0, t - length + 1))
            pmask[i, start : start + length] = 1
        if rng.random() < cfg.p_seed:
            pmask[i, : int(rng.integers(1, t // 2 + 1))] = 1
        if rng.random() < cfg.p_style:
            keep = np.ones(len(STYLE_NAMES), np.float32)
            if rng.random() < 0.5:
                keep[rng.integers(0, len(STYLE_NAMES))] = 0
            smask[i] = keep
    pose[pmask > 0] = poses[pmask > 0]
    style = ref_style * smask
    return pose, pmask, style, smask


def restyle_requests(style: np.ndarray, style_mask: np.ndarray, pose_mask: np.ndarray, word_ids: np.ndarray,
                     rng: np.random.Generator, p: float) -> np.ndarray:
    """Counterfactual style requests, in place: on a share ``p`` of the windows that have no pose
    control and are mostly speech, one style dimension is requested at a value drawn uniformly
    in [-2.5, 2.5] instead of the reference's own. There is no reference motion for such a
    request, so those windows (True in the returned (B,) mask) train only the style term
    (towards the request) and the adversarial term: the network learns to reach the whole
    style range, not only the styles its training windows happen to have. Windows mostly
    silent are left alone (silence means rest, whatever the style)."""
    b = len(style)
    out = np.zeros(b, bool)
    for i in range(b):
        if pose_mask[i].any() or (word_ids[i] > 0).mean() < 0.6 or rng.random() >= p:
            continue
        k = int(rng.integers(style.shape[-1]))
        style[i, :, k] = rng.uniform(-2.5, 2.5)
        style_mask[i, :, k] = 1.0
        out[i] = True
    return out


# -- training ---------------------------------------------------------------------------------


def _tensors(batch: dict, torch, device="cpu"):
    return (
        torch.as_tensor(batch["audio"], dtype=torch.float32, device=device),
        torch.as_tensor(batch["word_ids"], dtype=torch.long, device=device),
        torch.as_tensor(batch["onsets"], dtype=torch.float32, device=device),
        torch.as_tensor(batch["poses"], dtype=torch.float32, device=device),
    )


def validate(model, val: Windows, cfg: TrainConfig, count: int = 192, device="cpu") -> dict:
    """Held-out figures: Huber loss without controls, PCS (5 controlled frames mid-window), SCS."""
    import torch

    batch = val.fixed(count)
    audio, ids, onsets, ref = _tensors(batch, torch, device)
    b, t, _ = ref.shape
    z = torch.zeros(b, model.config["noise_dim"], device=device)
    zeros_p = torch.zeros_like(ref)
    zeros_m = torch.zeros(b, t, device=device)
    zeros_s = torch.zeros(b, t, len(STYLE_NAMES), device=device)
    with torch.no_grad():
        ref_style = style_of(ref)
        free = model(audio, ids, onsets, zeros_p, zeros_m, zeros_s, zeros_s, z)
        m = torch.zeros(b, t, device=device)
        frames = pcs_frames(t)  # SGToolkit Eq. 8: a 5-frame pose control in the middle, as sgt eval
        m[:, frames] = 1
        posed = model(audio, ids, onsets, ref * m[..., None], m, zeros_s, zeros_s, z)
        ones = torch.ones(b, t, len(STYLE_NAMES), device=device)
        styled = model(audio, ids, onsets, zeros_p, zeros_m, ref_style, ones, z)
        huber = torch.nn.functional.huber_loss(free, ref, delta=cfg.huber_delta).item()
        pcs = (posed - ref).abs()[:, frames].mean().item()
        scs = (style_of(styled) - ref_style).abs().mean().item()
    return {"val_huber": huber, "val_pcs": pcs, "val_scs": scs}


def learning_rate(cfg: TrainConfig, step: int) -> float:
    """Cosine decay from ``cfg.lr`` to ``cfg.lr * cfg.lr_floor`` over all the steps of the run."""
    total = max(1, cfg.epochs * cfg.steps_per_epoch)
    return cfg.lr * (cfg.lr_floor + (1 - cfg.lr_floor) * 0.5 * (1 + math.cos(math.pi * min(step, total) / total)))


def selection_score(row: dict) -> float:
    """Which epoch's weights to keep: held-out PCS and SCS, each relative to its target
    (SGToolkit's 0.014 and 0.249; lower is better). Style following overfits long before the
    pose terms stop improving, so the last epoch is often not the best one."""
    return row["val_pcs"] / 0.014 + row["val_scs"] / 0.249


class _Dist:
    """The process group when launched by ``torchrun`` (WORLD_SIZE > 1): NCCL on CUDA, gloo on
    CPU; a group of one otherwise. Rank 0 writes every file and reports progress."""

    def __init__(self, torch, want_cuda: bool) -> None:
        import os

        self.torch = torch
        self.world = int(os.environ.get("WORLD_SIZE", "1"))
        self.rank = int(os.environ.get("RANK", "0"))
        local = int(os.environ.get("LOCAL_RANK", "0"))
        cuda = want_cuda and torch.cuda.is_available()
        self.device = torch.device(f"cuda:{local}" if cuda else "cpu")
        if cuda:
            torch.cuda.set_device(self.device)
        self.group = None
        if self.world > 1:
            import torch.distributed as dist

            if not dist.is_initialized():
                dist.init_process_group("nccl" if cuda else "gloo")
            self.group = dist

    @property
    def main(self) -> bool:
        return self.rank == 0

    def wrap(self, module):
        if self.group is None:
            return module
        from torch.nn.parallel import DistributedDataParallel

        ids = [self.device.index] if self.device.type == "cuda" else None
        return DistributedDataParallel(module, device_ids=ids)

    def gather(self, obj) -> list:
        """Every rank's ``obj`` (a list by rank), on every rank."""
        if self.group is None:
            return [obj]
        out = [None] * self.world
        self.group.all_gather_object(out, obj)
        return out

    def agree(self, flag: bool) -> bool:
        """Rank 0's decision, on every rank."""
        return bool(self.gather(flag)[0])

    def close(self) -> None:
        if self.group is not None and self.group.is_initialized():
            self.group.barrier()
            self.group.destroy_process_group()


def _unwrap(module):
    return getattr(module, "module", module)


def weights_checksum(model) -> float:
    """A number that differs when any weight does (sum of |w| and w^2 over every parameter)."""
    return float(sum((p.detach().double().abs().sum() + p.detach().double().pow(2).sum()).item()
                     for p in _unwrap(model).parameters()))


def _checkpoint_difference(state: dict, config: dict, world: int) -> str:
    """What keeps a checkpoint from resuming: the settings that differ (``name`` then and now),
    or the number of processes."""
    saved = state.get("config") or {}
    changed = [f"{k} {saved.get(k)!r} (now {v!r})" for k, v in config.items() if k != "minutes" and saved.get(k) != v]
    if changed:
        return "other settings: " + ", ".join(changed)
    return f"{len(state.get('rngs', []))} processes (now {world})"


class CheckpointError(ValueError):
    """A checkpoint that cannot be resumed; one line naming the file and what to do."""


class TrainingDiverged(ValueError):
    """The loss or the validation score stopped being a finite number; one line saying when, and
    which files (if any) hold weights."""


#: What to do with a checkpoint that cannot be resumed.
_FRESH = "start afresh with --fresh (which replaces it), or train into another folder"


def read_checkpoint(path: Path) -> dict:
    """The dict :func:`train` saved in ``path``, loaded by torch's weights-only unpickler (tensors,
    numbers, strings, lists and dicts: a pickle that would build anything else, and so run code,
    is refused before any of it runs). Read by :func:`core.reading.read_bytes` (a FIFO or a
    device is refused unread), checked to be an uncompressed zip archive as ``torch.save``
    writes (memory is then bounded by the file's size), and its entries checked.
    :class:`CheckpointError` otherwise, in one line."""
    import pickle

    import torch

    try:
        data = read_bytes(path, "checkpoint")
    except InputFileError as exc:
        raise CheckpointError(f"{path}: {exc.reason}; {_FRESH}") from None
    except OSError as exc:
        raise CheckpointError(f"cannot read {path}: {exc.strerror or exc}; {_FRESH}") from None
    why = not_torch_archive(data)
    if why:
        raise CheckpointError(f"{path} is not a checkpoint of sgt train ({why}); {_FRESH}")
    try:
        state = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except pickle.UnpicklingError:
        raise CheckpointError(f"{path} holds something other than tensors and plain values (torch's weights-only "
                              f"loader refused it, so nothing in it ran); {_FRESH}") from None
    except Exception as exc:  # noqa: BLE001 - torch.load on a damaged file: see model.weights.load_weights
        raise CheckpointError(f"{path} is damaged ({exc.__class__.__name__}); {_FRESH}") from None
    bad = _checkpoint_fault(state)
    if bad:
        raise CheckpointError(f"{path} is not a checkpoint of sgt train ({bad}); {_FRESH}")
    return state


def _checkpoint_fault(state) -> str | None:
    """What a loaded checkpoint lacks of what :func:`train` saves, or None."""
    if not isinstance(state, dict):
        return f"it holds a {type(state).__name__}, not a dict"
    kinds = {"model": dict, "opt": dict, "rngs": list, "epoch": int, "config": dict, "best": float}
    wrong = [k for k, kind in kinds.items() if not isinstance(state.get(k), kind) or isinstance(state.get(k), bool)]
    if wrong:
        return f"{', '.join(wrong)} missing or of another type"
    if state["epoch"] < 0 or not all(isinstance(r, dict) for r in state["rngs"]):
        return "its epoch or random states are malformed"
    return None


def _diverged(out_dir: Path, epoch: int, what: str) -> str:
    """The line of a run that stopped in ``epoch`` (0-based) because ``what`` is not a number."""
    if epoch > 0:
        kept = (f"the files in {out_dir} are those of epoch {epoch}, the last that finished "
                "(generator.pt: the best epoch up to it)")
    else:
        kept = "no weights were written"
    return (f"training diverged in epoch {epoch + 1}, {what}; {kept}. Check the takes for extreme values "
            "(units, a wild joint) and the loss weights, or try another --seed")


def train(train_clips, val_clips, out_dir: Path, cfg: TrainConfig, *, resume: bool = True, progress=None, log=print):
    """Train (or resume) and return the model. Writes in ``out_dir``: checkpoint.pt (to resume),
    metrics.jsonl (a row per epoch), last.pt (the last epoch's weights) and generator.pt (the
    weights of the epoch with the best :func:`selection_score` on the validation split).

    Launched by ``torchrun --nproc_per_node N`` it trains one model on N processes with
    DistributedDataParallel (gloo on CPU, NCCL on CUDA): each rank draws its own
    ``cfg.batch / N`` windows a step, gradients are averaged, so the weights stay identical on
    every rank (each epoch's row records their checksums); rank 0 writes the files and a
    checkpoint holds every rank's random state, so a run resumes exactly."""
    import torch

    from model.net import Discriminator, GestureNet, PosteriorEncoder  # lazy: torch
    torch.set_num_threads(max(1, cfg.threads))
    torch.manual_seed(cfg.seed)
    dist = _Dist(torch, cfg.device != "cpu")
    dev = dist.device
    if not dist.main:
        progress, log = None, (lambda *_: None)
    out_dir = Path(out_dir)
    if dist.main:
        out_dir.mkdir(parents=True, exist_ok=True)
    ckpt_path = out_dir / "checkpoint.pt"
    metrics_path = out_dir / "metrics.jsonl"
    local_batch = max(1, math.ceil(cfg.batch / dist.world))

    data = Windows(train_clips, cfg.window)
    val = Windows(val_clips, cfg.window)
    model = GestureNet(cfg.net).to(dev)
    noise_dim = model.config["noise_dim"]
    enc = PosteriorEncoder(noise_dim).to(dev) if cfg.kl > 0 else None
    disc = Discriminator().to(dev) if cfg.beta > 0 else None
    gen_params = list(model.parameters()) + (list(enc.parameters()) if enc is not None else [])
    opt = torch.optim.Adam(gen_params, lr=cfg.lr)
    opt_d = torch.optim.Adam(disc.parameters(), lr=cfg.lr) if disc is not None else None
    rng = np.random.default_rng([cfg.seed, dist.rank])
    epoch0 = 0
    best = float("inf")
    if resume and (ckpt_path.exists() or ckpt_path.is_symlink()):
        state = read_checkpoint(ckpt_path)
        if state["config"] == asdict(cfg) | {"minutes": state["config"].get("minutes")} and \
                len(state["rngs"]) == dist.world:
            try:
                model.load_state_dict(state["model"])
                opt.load_state_dict(state["opt"])
                if enc is not None:
                    enc.load_state_dict(state["enc"])
                if disc is not None and state.get("disc") is not None:
                    disc.load_state_dict(state["disc"])
                    opt_d.load_state_dict(state["opt_d"])
                rng.bit_generator.state = state["rngs"][dist.rank]
            except (RuntimeError, KeyError, ValueError, TypeError, AttributeError, IndexError) as exc:
                first = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
                raise CheckpointError(f"{ckpt_path} does not fit the network of its own settings ({first[:200]}); "
                                      f"{_FRESH}") from None
            epoch0 = state["epoch"]
            best = state["best"]
            log(f"resumed from {ckpt_path} after epoch {epoch0}")
        else:
            # refused rather than started afresh: the first epoch would replace the checkpoint
            raise CheckpointError(f"{ckpt_path} was made with {_checkpoint_difference(state, asdict(cfg), dist.world)}; "
                                  f"give the settings it was made with to resume it, or {_FRESH}")
    # wrapped after loading: DistributedDataParallel broadcasts rank 0's weights to every rank
    net, encoder, critic = dist.wrap(model), (dist.wrap(enc) if enc is not None else None), \
        (dist.wrap(disc) if disc is not None else None)
    started = time.monotonic()
    total_steps = cfg.epochs * cfg.steps_per_epoch
    for epoch in range(epoch0, cfg.epochs):
        model.train()
        sums = {k: 0.0 for k in ("loss", "huber", "ctrl", "vel", "style", "kl", "gan", "disc", "hist")}
        for step in range(cfg.steps_per_epoch):
            lr = learning_rate(cfg, epoch * cfg.steps_per_epoch + step)
            for group in opt.param_groups + (opt_d.param_groups if opt_d else []):
                group["lr"] = lr
            batch = data.sample(rng, local_batch)
            audio, ids, onsets, ref = _tensors(batch, torch, dev)
            with torch.no_grad():
                ref_style = style_of(ref)
            pose, pmask, sty, smask = simulate_controls(batch["poses"], ref_style.cpu().numpy(), rng, cfg)
            target = ref_style
            keep = torch.ones(local_batch, device=dev)  # windows the reference terms apply to
            if cfg.p_restyle > 0:
                restyled = restyle_requests(sty, smask, pmask, batch["word_ids"], rng, cfg.p_restyle)
                if restyled.any():
                    target = torch.as_tensor(np.where(smask > 0, sty, ref_style.cpu().numpy()), device=dev)
                    keep = torch.as_tensor(~restyled, dtype=torch.float32, device=dev)
            z = torch.as_tensor(rng.standard_normal((local_batch, noise_dim)), dtype=torch.float32, device=dev)
            loss = torch.zeros((), device=dev)
            if encoder is not None:
                # conditional VAE: the noise of an uncontrolled window is drawn from the encoder's
                # posterior of its reference (except for cfg.p_prior of them); a window with any
                # pose or style control gets noise from the prior, as generation draws it, so the
                # network learns to follow the controls, not what the posterior says of the reference
                mu, logvar = encoder(ref)
                eps = torch.as_tensor(rng.standard_normal((local_batch, noise_dim)), dtype=torch.float32, device=dev)
                free = (pmask.max(axis=1) == 0) & (smask.reshape(local_batch, -1).max(axis=1) == 0)
                post = torch.as_tensor(free & (rng.random(local_batch) >= cfg.p_prior), device=dev)
                z = torch.where(post[:, None], mu + torch.exp(0.5 * logvar) * eps, z)
                kl = (0.5 * (mu.pow(2) + logvar.exp() - 1.0 - logvar).sum(-1) * post).sum() / post.sum().clamp_min(1)
                loss = loss + cfg.kl * kl
                sums["kl"] += kl.item()
            out = net(audio, ids, onsets, torch.as_tensor(pose, device=dev), torch.as_tensor(pmask, device=dev),
                      torch.as_tensor(sty, device=dev), torch.as_tensor(smask, device=dev), z)
            kept = keep.sum().clamp_min(1)
            huber = (torch.nn.functional.huber_loss(out, ref, delta=cfg.huber_delta, reduction="none").mean((1, 2))
                     * keep).sum() / kept
            style_loss = (style_of(out) - target).abs().mean()
            loss = loss + cfg.alpha * huber + cfg.gamma * style_loss
            m = torch.as_tensor(pmask, device=dev)
            if cfg.ctrl > 0:
                ctrl = ((out - ref).abs().mean(-1) * m).sum() / m.sum().clamp_min(1)
                loss = loss + cfg.ctrl * ctrl
                sums["ctrl"] += ctrl.item()
            if cfg.vel > 0:
                vel = ((torch.diff(out, dim=1) - torch.diff(ref, dim=1)).abs().mean((1, 2)) * keep).sum() / kept
                loss = loss + cfg.vel * vel
                sums["vel"] += vel.item()
            if cfg.hist > 0:
                hist = soft_speed_hellinger(out, ref, keep)
                loss = loss + cfg.hist * hist
                sums["hist"] += hist.item()
            if critic is not None:
                # discriminator step (non-saturating GAN); real and generated windows in one pass
                d_out = critic(torch.cat([ref, out.detach()]))
                d_real, d_fake = d_out[: len(ref)], d_out[len(ref):]
                d_loss = torch.nn.functional.softplus(-d_real).mean() + torch.nn.functional.softplus(d_fake).mean()
                opt_d.zero_grad()
                d_loss.backward()
                opt_d.step()
                # the generator's term: through the unwrapped critic with its weights frozen, so its
                # backward neither accumulates critic gradients nor fires the DDP hooks
                disc.requires_grad_(False)
                gan = torch.nn.functional.softplus(-disc(out)).mean()
                loss = loss + cfg.beta * gan
                sums["gan"] += gan.item()
                sums["disc"] += d_loss.item()
            opt.zero_grad()
            loss.backward()
            # the gradients are averaged over the ranks before this: every rank sees the same norm and stops together
            norm = torch.nn.utils.clip_grad_norm_(gen_params, 1.0)
            if not torch.isfinite(norm):  # before the step: the weights stay those of the last good step
                raise TrainingDiverged(_diverged(out_dir, epoch, f"step {step + 1}: the loss is {loss.item():g} "
                                                                f"and its gradient's norm {norm.item():g}"))
            opt.step()
            if disc is not None:
                disc.requires_grad_(True)
            sums["loss"] += loss.item()
            sums["huber"] += huber.item()
            sums["style"] += style_loss.item()
            if progress:
                progress(epoch * cfg.steps_per_epoch + step + 1, total_steps, f"epoch {epoch + 1} loss {loss.item():.3f}")
        model.eval()
        row = {"epoch": epoch + 1, **{k: v / cfg.steps_per_epoch for k, v in sums.items()},
               **validate(model, val, cfg, device=dev)}
        row["score"] = selection_score(row)
        if not math.isfinite(row["score"]):  # checked before anything of the epoch is written
            raise TrainingDiverged(_diverged(out_dir, epoch, f"validation: the score is {row['score']:g}"))
        row["best"] = row["score"] < best
        row["minutes"] = (time.monotonic() - started) / 60
        if dist.world > 1:
            row["ranks"] = dist.world
            row["rank_checksums"] = dist.gather(weights_checksum(model))
        rngs = dist.gather(rng.bit_generator.state)
        best = min(best, row["score"])
        if dist.main:
            with open(metrics_path, "a", encoding="utf-8") as f:
                f.write(json.dumps(row) + "\n")
            log(" ".join(f"{k}={v:.4f}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()))
            buf = io.BytesIO()
            torch.save({"model": model.state_dict(), "opt": opt.state_dict(),
                        "enc": enc.state_dict() if enc is not None else None,
                        "disc": disc.state_dict() if disc else None, "opt_d": opt_d.state_dict() if opt_d else None,
                        "rngs": rngs, "epoch": epoch + 1, "config": asdict(cfg), "best": best}, buf)
            atomic_write(ckpt_path, buf.getvalue())
            meta = {"train_config": asdict(cfg), "epochs_done": epoch + 1, "validation": row}
            save_weights(out_dir / "last.pt", model, meta=meta)
            if row["best"]:
                save_weights(out_dir / "generator.pt", model, meta=meta)
        over = cfg.minutes is not None and (time.monotonic() - started) / 60 >= cfg.minutes
        if dist.agree(over):
            log(f"time budget of {cfg.minutes} min reached after epoch {epoch + 1}")
            break
    dist.close()
    if dist.main and (out_dir / "generator.pt").exists():
        log("measuring the training takes' postures and drifts for generator.pt")
        record_takes(out_dir / "generator.pt", train_clips, progress=progress)
    return model
