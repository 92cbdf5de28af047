#!/usr/bin/env bash
# Kiji's main job: a design session on the default body that writes a garment and a picture.
# For now the session is a drape: out/drape.glb and out/drape.png. Extra arguments go to 'kiji drape'.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
build/bin/kiji drape --out out/drape.glb --picture out/drape.png "$@"
