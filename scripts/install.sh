#!/usr/bin/env bash
# Installs everything MoRF Studio needs on a fresh Debian machine into ./.venv.
# Safe to re-run: finished steps are skipped quickly.
set -euo pipefail
cd "$(dirname "$0")/.."

# libgomp1: OpenMP threads for the player's compiled full-resolution pass (numba's omp layer,
# twice as fast as its fallback)
if ! ldconfig -p 2>/dev/null | grep -q "libEGL.so.1" || ! ldconfig -p 2>/dev/null | grep -q "libGL.so.1" \
    || ! ldconfig -p 2>/dev/null | grep -q "libgomp.so.1"; then
  echo "[install] Debian packages: libegl1 libgl1 libgomp1"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libegl1 libgl1 libgomp1 >/dev/null
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "[install] creating .venv"
  "$PY" -m venv .venv
fi
. .venv/bin/activate
python -m pip install -q --disable-pip-version-check --upgrade pip wheel setuptools
echo "[install] Python packages (torch==2.13.0 CPU, anny, onnxruntime, moderngl, imgui-bundle, PyAV, Ray, ...)"
python -m pip install -q --disable-pip-version-check -e ".[test,video,ray]"
# MediaPipe declares jax and the non-headless OpenCV; its pose solution needs neither.
if ! python -c "import mediapipe" 2>/dev/null; then
  python -m pip install -q --disable-pip-version-check --no-deps "mediapipe==0.10.14"
fi
# A shared Anny cache (about 790 MB, built once in about a minute) keeps later runs fast.
export ANNY_CACHE_DIR="${ANNY_CACHE_DIR:-$HOME/.cache/anny}"
python -m morf.body.warmup
echo "[install] done"
