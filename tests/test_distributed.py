"""sgt train on two CPU processes (torchrun, gloo): one model, the same on both ranks, that
learns, and resumes exactly from its checkpoint."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch")

ROOT = Path(__file__).resolve().parent.parent


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def torchrun(out: Path, *args) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "torch.distributed.run", "--nproc_per_node", "2", "--master_addr", "127.0.0.1",
           "--master_port", str(_free_port()), str(ROOT / "tests" / "ddp_worker.py"), str(out), *map(str, args)]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc


def test_two_processes_train_one_model_and_resume(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    torchrun(a, 4)
    rank0, rank1 = (torch.load(a / f"rank{r}.pt") for r in (0, 1))
    assert rank0.keys() == rank1.keys()
    assert all(torch.equal(rank0[k], rank1[k]) for k in rank0)  # one model: the same weights on both ranks
    rows = [json.loads(line) for line in (a / "metrics.jsonl").read_text().splitlines()]
    assert [r["epoch"] for r in rows] == [1, 2, 3, 4] and all(r["ranks"] == 2 for r in rows)
    assert all(len(set(r["rank_checksums"])) == 1 for r in rows)  # in step after every epoch
    # learning: the training loss falls (the 2 validation clips after 4 short epochs are noise:
    # their loss moved by +-3 % when the gesture library that makes the synthetic clips grew)
    assert rows[-1]["huber"] < 0.7 * rows[0]["huber"]
    assert all(np.isfinite(r["val_huber"]) for r in rows)
    # only rank 0 writes, in the usual files; the shipped-format weights load
    from model.weights import load_weights

    assert {p.name for p in a.iterdir()} == {"checkpoint.pt", "metrics.jsonl", "last.pt", "generator.pt", "rank0.pt",
                                             "rank1.pt"}
    last, _ = load_weights(a / "last.pt")
    assert all(torch.equal(last.state_dict()[k], rank0[k]) for k in rank0)
    # a run stopped after its first epoch (a time budget of 0), then resumed: the same weights
    torchrun(b, 4, 0)
    assert [json.loads(line)["epoch"] for line in (b / "metrics.jsonl").read_text().splitlines()] == [1]
    torchrun(b, 4)
    assert [json.loads(line)["epoch"] for line in (b / "metrics.jsonl").read_text().splitlines()] == [1, 2, 3, 4]
    for r in (0, 1):
        resumed = torch.load(b / f"rank{r}.pt")
        assert all(torch.equal(resumed[k], rank0[k]) for k in rank0)
