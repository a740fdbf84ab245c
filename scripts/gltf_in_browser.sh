#!/usr/bin/env bash
# Load an exported .glb in a renderer we did not write: three.js's GLTFLoader in headless Chromium.
#   scripts/gltf_in_browser.sh AVATAR.glb OUT_DIR [--times 0,0.1] [--pose POSE.json] [--chromium BIN]
# Writes OUT_DIR/report.json, positions.npz, screenshot.png; exits non-zero when a check fails.
# Once: apt-get install chromium-headless-shell (or chromium); python tools/gltf-check/fetch_three.py (scripts/test.sh does both).
# See docs/formats.md, "Checked in three.js".
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
PY=${PYTHON:-}
if [ -z "$PY" ]; then
  if [ -x "$ROOT/.venv/bin/python" ]; then PY="$ROOT/.venv/bin/python"; else PY=python3; fi
fi
exec "$PY" "$ROOT/tools/gltf-check/gltf_in_browser.py" "$@"
