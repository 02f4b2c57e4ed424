"""Record the training takes' postures and drifts (model/take_posture.py) in weights files
trained before ``sgt train`` measured them itself (or before it measured drifts).

    python scripts/record_takes.py --corpus data/corpus model/weights/generator.pt [runs/X/generator.pt ...]

For each weights file: each training clip's posture (the clip's mean pose minus the mean pose
this network makes on the clip's speech with no controls) and drift (the same difference
low-passed over time, less the posture), written into the file with everything else kept. Re-export the shipped
weights afterwards (``python scripts/export_onnx.py``): the file's hash changes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main() -> int:
    from model.training.corpus import CorpusError, load_corpus
    from model.training.takes import record_takes
    from model.weights import WeightsError
    from sgt_tui.progress import ProgressBar

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--corpus", default="data/corpus", help="the corpus the weights were trained on (default data/corpus)")
    ap.add_argument("weights", nargs="+", help="weights files to update")
    args = ap.parse_args()
    try:
        clips = load_corpus(args.corpus, "train")
    except (CorpusError, OSError) as exc:
        print(f"record_takes: cannot load the corpus at {args.corpus}: {exc}", file=sys.stderr)
        return 1
    for path in args.weights:
        try:
            takes = record_takes(path, clips, progress=ProgressBar(Path(path).parent.name or "takes"))
        except WeightsError as exc:
            print(f"record_takes: {exc}", file=sys.stderr)
            return 1
        print(f"{path}: recorded {len(takes)} training takes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
