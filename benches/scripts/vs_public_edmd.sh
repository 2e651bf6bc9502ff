#!/bin/sh
# Times densepack and F. Smallenburg's public EDMD code ("Single": neighbour lists, one event
# per particle; github.com/FSmallenburg/EDMD, EPJ E 45:22, 2022) on the same hard-sphere fluid,
# alternating the two programs, with /usr/bin/time.
#
#   benches/scripts/vs_public_edmd.sh SRC_DIR [N] [ROUNDS]
#
# SRC_DIR is a checkout of that repository (this script never ships or downloads it). N
# spheres (default 10000), ROUNDS alternations (default 3). Environment: DENSEPACK (binary,
# default target/release/densepack), PUB_CFLAGS (compiler flags for the public code; default:
# its own Makefile's), PUB_SPAN (time units per timed leg of the public code, default 10),
# MEASURED (densepack collisions per particle in the measured stage, default 300), KEEP (set:
# keep the scratch directory).
#
# Protocol (BENCHMARKS.md, "Fluid"): densepack seeds N spheres by RSA at phi = 0.3, grows
# them at relative rate 0.1 to phi = 0.5 and runs 20 collisions per particle without growth
# ("pre"); the whole scene adds the measured stage. densepack's rate is the measured stage's
# collisions over the CPU seconds of the whole scene less those of "pre". The public code
# starts from the "pre" packing (lengths scaled to diameter 1) and runs PUB_SPAN and
# 2 * PUB_SPAN time units; its rate is the difference of the collisions it prints over the
# difference of the CPU seconds, so start-up and reading cancel. CPU seconds are user time.
set -eu

if [ $# -lt 1 ] || [ ! -d "$1" ]; then
    echo "usage: $0 SRC_DIR [N] [ROUNDS]  (SRC_DIR: a checkout of FSmallenburg/EDMD)" >&2
    exit 2
fi
SRC=$(cd "$1" && pwd)
N=${2:-10000}
ROUNDS=${3:-3}
DENSEPACK=${DENSEPACK:-target/release/densepack}
PUB_SPAN=${PUB_SPAN:-10}
MEASURED=${MEASURED:-300}
case $N in '' | *[!0-9]*) echo "N must be a positive integer, got '$N'" >&2; exit 2 ;; esac
case $ROUNDS in '' | *[!0-9]*) echo "ROUNDS must be a positive integer" >&2; exit 2 ;; esac
[ -x "$DENSEPACK" ] || { echo "no densepack binary at $DENSEPACK (cargo build --release)" >&2; exit 2; }
[ -f "$SRC/Single/Makefile" ] || { echo "$SRC/Single/Makefile missing: not an EDMD checkout" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "/usr/bin/time is needed (apt-get install time)" >&2; exit 2; }
DENSEPACK=$(cd "$(dirname "$DENSEPACK")" && pwd)/$(basename "$DENSEPACK")

WORK=$(mktemp -d)
if [ -z "${KEEP:-}" ]; then trap 'rm -rf "$WORK"' EXIT; fi
echo "scratch directory $WORK" >&2

# The box holds N spheres of diameter 1 at phi = 0.3 (the RSA seeding); growth then scales
# the radii up to phi = 0.5.
EDGE=$(awk -v n="$N" 'BEGIN { printf "%.6f", (n * 3.141592653589793 / 6 / 0.3) ^ (1 / 3) }')
scene() { # $1 = file, $2 = 1 to add the measured stage
    cat >"$1" <<SCENE
seed = 1
queue = "calendar"
[container]
type = "box"
size = [$EDGE, $EDGE, $EDGE]
periodic = [true, true, true]
[particles]
count = $N
diameter = 1.0
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = 0.1
until = { packing_fraction = 0.5 }
[[stage]]
growth = "none"
until = { collisions_per_particle = 20 }
SCENE
    if [ "$2" = 1 ]; then
        printf '[[stage]]\ngrowth = "none"\nuntil = { collisions_per_particle = %s }\n' "$MEASURED" >>"$1"
    fi
}
scene "$WORK/pre.toml" 0
scene "$WORK/whole.toml" 1

# The public code, built from a scratch copy with its own Makefile; only its parameter lines
# (global variables at the top of the source) are edited: read init.sph, run PUB_SPAN units,
# no snapshots.
mkdir "$WORK/pub"
cp "$SRC/Single/"* "$WORK/pub/"
[ -f "$WORK/pub/mt19937ar.c" ] || cp "$SRC/Grow/mt19937ar.c" "$WORK/pub/"
sed -i -e 's/^int initialconfig = [0-9]*;/int initialconfig = 0;/' \
    -e 's/^char inputfilename\[100\] = "[^"]*";/char inputfilename[100] = "init.sph";/' \
    -e 's/^int makesnapshots = [0-9]*;/int makesnapshots = 0;/' "$WORK/pub/mdSingle.c"
for t in 1 2; do
    mkdir "$WORK/pub$t"
    sed "s/^double maxtime = [0-9.e+-]*;/double maxtime = $((t * PUB_SPAN));/" \
        "$WORK/pub/mdSingle.c" >"$WORK/pub$t/mdSingle.c"
    cp "$WORK/pub/"*.h "$WORK/pub/Makefile" "$WORK/pub/mt19937ar.c" "$WORK/pub$t/"
    if [ -n "${PUB_CFLAGS:-}" ]; then
        make -s -C "$WORK/pub$t" CFLAGS="$PUB_CFLAGS" >&2
    else
        make -s -C "$WORK/pub$t" >&2
    fi
done

# The starting fluid: densepack's "pre" packing, scaled so that the diameter is 1.
"$DENSEPACK" run "$WORK/pre.toml" --out "$WORK/pre.json" >/dev/null 2>&1
"$DENSEPACK" export "$WORK/pre.json" --format csv --out "$WORK/pre.csv" >/dev/null
awk -F, -v n="$N" -v edge="$EDGE" 'NR == 1 { next }
    { x[NR] = $1; y[NR] = $2; z[NR] = $3; r = $4 }
    END { s = 0.5 / r; printf "%d\n%.12f %.12f %.12f\n", n, edge * s, edge * s, edge * s
          for (i = 2; i <= NR; i++) printf "a %.12f %.12f %.12f 0.5\n", x[i] * s, y[i] * s, z[i] * s }' \
    "$WORK/pre.csv" >"$WORK/init.sph"
cp "$WORK/init.sph" "$WORK/pub1/"
cp "$WORK/init.sph" "$WORK/pub2/"

cpu() { # user seconds of a command run in directory $1; its stdout in $WORK/out
    dir=$1
    shift
    (cd "$dir" && /usr/bin/time -f %U -o "$WORK/cpu" "$@" >"$WORK/out" 2>/dev/null)
    cat "$WORK/cpu"
}
densepack_collisions() { sed -n 's/.* collisions \([0-9]*\) .*/\1/p' "$WORK/out" | head -n 1; }
public_collisions() { sed -n 's/.*Collisions: \([0-9]*\),.*/\1/p' "$WORK/out" | tail -n 1; }

echo "round,densepack_M_collisions_per_cpu_s,public_M_collisions_per_cpu_s,ratio"
i=1
while [ "$i" -le "$ROUNDS" ]; do
    u_pre=$(cpu "$WORK" "$DENSEPACK" run "$WORK/pre.toml" --out "$WORK/p.json")
    c_pre=$(densepack_collisions)
    u_whole=$(cpu "$WORK" "$DENSEPACK" run "$WORK/whole.toml" --out "$WORK/w.json")
    c_whole=$(densepack_collisions)
    u1=$(cpu "$WORK/pub1" ./md)
    c1=$(public_collisions)
    u2=$(cpu "$WORK/pub2" ./md)
    c2=$(public_collisions)
    awk -v i="$i" -v cp="$c_pre" -v cw="$c_whole" -v up="$u_pre" -v uw="$u_whole" \
        -v c1="$c1" -v c2="$c2" -v u1="$u1" -v u2="$u2" 'BEGIN {
        d = (cw - cp) / (uw - up) / 1e6; p = (c2 - c1) / (u2 - u1) / 1e6
        printf "%d,%.3f,%.3f,%.3f\n", i, d, p, d / p }'
    i=$((i + 1))
done
# The public code's own summary of its last run, to check the fluid: packing fraction 0.5,
# pressure P* = beta P sigma^3 (Carnahan-Starling: Z = 13.0, P* = 6 phi Z / pi = 12.4).
grep -E 'Packing fraction  |Measured pressure' "$WORK/out" >&2 || true
