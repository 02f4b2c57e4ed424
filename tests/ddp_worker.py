"""Run by tests/test_distributed.py under torchrun: trains on the synthetic clips and saves
this rank's final weights (rank{RANK}.pt) next to the run's files. Arguments: OUT EPOCHS
[MINUTES] (a time budget; 0 stops after the first epoch, an interrupted run)."""

import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import torch  # noqa: E402
from synthetic import synthetic_clips  # noqa: E402

from model.training.train import TrainConfig, train  # noqa: E402


def main() -> None:
    out, epochs = Path(sys.argv[1]), int(sys.argv[2])
    minutes = float(sys.argv[3]) if len(sys.argv) > 3 else None  # 0: stop after the first epoch
    clips = synthetic_clips(8, 90, seed=2)
    cfg = TrainConfig(epochs=epochs, steps_per_epoch=6, batch=8, threads=1, kl=0.01, device="cpu", lr=2e-3,
                      minutes=minutes)
    model = train(clips[:6], clips[6:], out, cfg, resume=True, log=lambda s: None)
    torch.save(model.state_dict(), out / f"rank{os.environ['RANK']}.pt")


if __name__ == "__main__":
    main()
