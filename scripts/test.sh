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
.venv/bin/python tools/gltf-check/fetch_three.py || echo "[test] no three.js: the glTF browser check is skipped"
.venv/bin/python tools/web-player/fetch_ort.py || echo "[test] no onnxruntime-web: the web player tests are skipped"
. .venv/bin/activate
python -m pytest -q -p no:cacheprovider tests "$@"
