"""Training settings (no numpy or torch import, so ``sgt train --help`` stays fast)."""

from __future__ import annotations

from dataclasses import dataclass, field

#: Training window in frames. Shorter than the inference window (model.neural.WINDOW = 60) so
#: that 96% of the corpus frames are usable (its clips are 20-206 frames, median 69); the
#: network is length-agnostic.
WINDOW = 40


@dataclass
class TrainConfig:
    epochs: int = 60
    steps_per_epoch: int = 60
    batch: int = 48
    lr: float = 5e-4
    lr_floor: float = 0.05  # the cosine schedule ends at lr * lr_floor
    window: int = WINDOW
    alpha: float = 500.0  # Huber pose term
    beta: float = 5.0  # adversarial term; 0 switches it off
    gamma: float = 5.0  # style-consistency term
    huber_delta: float = 0.05
    ctrl: float = 100.0  # L1 on pose-controlled frames; 0 switches it off
    vel: float = 50.0  # L1 on velocities; 0 switches it off
    hist: float = 2.0  # Hellinger distance of the joint-speed histograms (model.training.speed_hist); 0 = off
    kl: float = 0.01  # KL weight of the conditional-VAE noise (a training-only posterior encoder); 0 = off
    p_prior: float = 0.0  # with the encoder: share of uncontrolled windows whose noise comes from the prior
    # (controlled windows always get the prior's)
    p_restyle: float = 0.25  # share of speech windows given a counterfactual style request (train.restyle_requests)
    p_drop_all: float = 0.25
    p_pose: float = 0.5
    p_seed: float = 0.5
    p_style: float = 0.5
    seed: int = 0
    threads: int = 2
    device: str = "auto"  # "auto": CUDA when present, else CPU; "cpu" forces the CPU
    minutes: float | None = None  # stop after this much wall time (finishing the epoch)
    net: dict = field(default_factory=dict)


#: The flow engine's training window in frames: the window it samples in (model.neural.WINDOW).
FLOW_WINDOW = 60


@dataclass
class FlowConfig:
    """Settings of ``sgt train --engine flow`` (:func:`model.training.train_flow.train_flow`)."""

    epochs: int = 60
    steps_per_epoch: int = 100
    batch: int = 64
    lr: float = 1e-3
    lr_floor: float = 0.05  # the cosine schedule ends at lr * lr_floor
    window: int = FLOW_WINDOW
    ema: float = 0.999  # decay of the weights' moving average, which is what ships
    t_mean: float = 0.0  # flow times: logit-normal (Esser et al. 2024), mean and spread of the logit,
    t_std: float = 1.0
    t_uniform: float = 0.2  # and this share uniform in [0, 1) (the few-step sampler starts at t = 0)
    p_drop_all: float = 0.25  # control simulation (model.training.train.simulate_controls)
    p_pose: float = 0.5
    p_seed: float = 0.5
    p_style: float = 0.5
    seed: int = 0
    threads: int = 2
    device: str = "auto"
    minutes: float | None = None  # stop after this much wall time (finishing the epoch)
    net: dict = field(default_factory=dict)
    teacher: str | None = None  # flow weights to distil into a sampler of the steps net["times"] sets (None: train a flow)
    substeps: int = 4  # with a teacher: its Euler steps for each of the student's


#: ``sgt train --engine flow --teacher``'s defaults where distillation's differ from training a
#: flow: the student starts as its teacher, so a few short epochs, a small step and a short
#: average (the shipped student's settings, docs/model.md).
DISTIL_DEFAULTS = {"epochs": 5, "steps_per_epoch": 60, "batch": 32, "lr": 2e-4, "ema": 0.99}
