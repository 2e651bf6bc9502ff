#!/bin/sh
# Regenerates the README's figures (docs/img/section.svg, sieve.svg, convergence.svg) by the
# README's quick-start commands, steps 1-3, in a scratch directory:
#
#   docs/img/regenerate.sh [DENSEPACK]
#
# DENSEPACK is the binary (default target/release/densepack; build it with
# `cargo build --release`). Run from the repository root. Same version, same figures: the
# packing depends only on the scene and its seed; only the run log's wall-clock times vary.
set -eu
DENSEPACK=${1:-target/release/densepack}
[ -x "$DENSEPACK" ] || { echo "no densepack binary at $DENSEPACK (cargo build --release)" >&2; exit 2; }
[ -d docs/img ] || { echo "run from the repository root" >&2; exit 2; }
DENSEPACK=$(cd "$(dirname "$DENSEPACK")" && pwd)/$(basename "$DENSEPACK")
OUT=$(pwd)/docs/img
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cd "$WORK"

# 1. Grading curve -> sizes (a runnable scene).
"$DENSEPACK" take B16 --phi-m 0.7 --d-min 4 --box 50,50,50 --seed 1 --scene concrete.toml >/dev/null
# 2. A gap for the mesher.
cat >>concrete.toml <<'SCENE'

[[stage]]
growth = "absolute"
rate = 0.01
until = { gap = 0.5 }
SCENE
# 3. Pack, check, look.
"$DENSEPACK" run concrete.toml --out concrete.json --run-log concrete.log >/dev/null
"$DENSEPACK" verify concrete.json --grading B16 --d-min 4 >/dev/null
"$DENSEPACK" plot section concrete.json --axis z --at 25 --out "$OUT/section.svg"
"$DENSEPACK" plot sieve concrete.json --out "$OUT/sieve.svg"
"$DENSEPACK" plot convergence concrete.log --out "$OUT/convergence.svg"
echo "wrote $OUT/section.svg, sieve.svg, convergence.svg" >&2
