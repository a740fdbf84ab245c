#!/usr/bin/env bash
# Install everything, then run the tests (the README's second command).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install.sh
. .venv/bin/activate
python -m pytest -q -p no:cacheprovider tests "$@"
