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
# Three pytest-xdist workers on two cores (MORF_TEST_WORKERS to change), each taking whole test
# files so that a module's fixtures are built once; many tests wait on child processes, the
# browser or the X server, so a third worker fills those waits (quiet 2-core Xeon: the suite in
# 6 min 13 s with three workers against 6 min 41 s with two). Torch threads are split between the
# workers (tests/conftest.py). MORF_TEST_WORKERS=0 runs everything in this process.
# The slowest files start first (tests/conftest.py SLOWEST_FILES; --no-loadscope-reorder keeps that
# order instead of xdist's most-tests-first).
# Bytecode is cached even where the environment turns it off (PYTHONDONTWRITEBYTECODE): the suite
# starts over a hundred Python processes that import morf, and each pytest worker would rewrite
# every test module's asserts again.
unset PYTHONDONTWRITEBYTECODE
python -m pytest -q -p no:cacheprovider -n "${MORF_TEST_WORKERS:-3}" --dist loadfile --no-loadscope-reorder tests "$@"
