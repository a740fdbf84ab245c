#!/usr/bin/env bash
# Install everything, then run the tests (the README's second command).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh
# The glTF browser check (tests/export/test_gltf_browser.py): headless Chromium from Debian and the
# pinned three.js; without them those tests are skipped, the others run.
if ! command -v chromium-headless-shell >/dev/null && ! command -v chromium >/dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
      chromium-headless-shell >/dev/null; } || echo "[test] no headless Chromium: the glTF browser check is skipped"
fi
# The studio's real-window tests (tests/studio/test_x_*.py) drive an X server with xdotool.
if ! command -v Xvfb >/dev/null || ! command -v xdotool >/dev/null; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  { $SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
      xvfb xdotool >/dev/null; } || echo "[test] no Xvfb/xdotool: the studio's real-window tests are skipped"
fi
.venv/bin/python tools/gltf-check/fetch_three.py || echo "[test] no three.js: the glTF browser check is skipped"
.venv/bin/python tools/web-player/fetch_ort.py || echo "[test] no onnxruntime-web: the web player tests are skipped"
. .venv/bin/activate
# Two pytest-xdist workers (MORF_TEST_WORKERS to change), each taking whole test files so that a
# module's fixtures are built once; on 2 cores this took the motion, io, raster and body tests from
# 229 s to 131 s (shared machine, load 5-6). Torch threads are split between the workers
# (tests/conftest.py). MORF_TEST_WORKERS=0 runs everything in this process.
python -m pytest -q -p no:cacheprovider -n "${MORF_TEST_WORKERS:-2}" --dist loadfile tests "$@"
