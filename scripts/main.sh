#!/usr/bin/env bash
# Kiji's main job: the 2006 paper's experiment (its section 5) as a Python design session on the
# default body - drape, cut away what is not needed, sew, paint letters - writing out/garment.glb and
# out/garment.png. Extra arguments go to the experiment script (see its --help).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
.venv/bin/kiji run python/kiji/examples/experiment.py --out out/garment.glb --picture out/garment.png "$@"
