"""Export the generator weights to ONNX for fast inference (onnxruntime, no torch import).

    python scripts/export_onnx.py [--weights model/weights/generator.pt] [-o OUT.onnx]

Run it whenever the weights change (DEVELOPERS.md, "Retraining and shipping weights"): the
export records the SHA-256 of the weights file, `sgt generate` uses it only while that hash
matches (else it falls back to PyTorch), and tests/test_runtime.py fails while the shipped
model/weights/generator.onnx is stale. Prints the largest difference from PyTorch's output
on random inputs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main() -> int:
    from model.runtime import export_onnx, largest_difference
    from model.weights import DEFAULT_WEIGHTS, WeightsError

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weights", default=str(DEFAULT_WEIGHTS), help="weights file (default: the shipped one)")
    ap.add_argument("-o", "--output", help="ONNX file to write (default: beside the weights, .onnx)")
    args = ap.parse_args()
    try:
        out = export_onnx(args.weights, args.output)
        diff = largest_difference(args.weights, out)
    except WeightsError as exc:
        print(f"export_onnx: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {out}; largest difference from PyTorch on random windows: {diff:.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
