#!/usr/bin/env bash
# Install everything sgt needs on a fresh Debian machine, then run the main job on a shipped
# example. Safe to run again. Usage: bash scripts/install.sh
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
PY="${PYTHON:-python3}"

echo "==> system packages (espeak-ng: speech; EGL/OSMesa: offscreen rendering; fortunes: training sentences; tmux: terminal tests)"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    espeak-ng libespeak-ng1 tmux libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6 fortunes fortunes-min >/dev/null

echo "==> PyTorch (CPU build)"
"$PY" -m pip install -q torch==2.13.0

echo "==> sgt and its Python dependencies"
"$PY" -m pip install -q -e '.[dev]'

echo "==> main job: check and compile examples/mall_guide.sgt"
mkdir -p out
sgt check examples/*.sgt
sgt compile examples/mall_guide.sgt -o out/mall_guide.plan.json --npz out/mall_guide.controls.npz
echo "done: see out/mall_guide.plan.json"
