#!/usr/bin/env bash
# Exports small packings in every format and reads them back with real readers: Gmsh meshes
# the .geo in 3D (second order), meshio reads meshes, .vtu and Abaqus .inp files, the VTK
# Python package reads .vti, numpy reads .npy, raw, .csv, .xyzd and LAMMPS data files. Checks are in check_exports.py. Called by .ci/run after the Rust tests.
#
# Readers: Debian's gmsh (installed with apt-get when missing and running as root), numpy,
# meshio and vtk from PyPI, installed into a virtual environment of the project
# (target/ci-venv, kept between runs), never into the system Python: a fresh Debian's Python
# is "externally managed" and refuses pip there. Debian's python3 needs the python3-venv
# package for `python3 -m venv` (installed with apt-get when missing and running as root).
# On a developer machine without apt/root the script says what is missing and fails.
set -euo pipefail
cd "$(dirname "$0")/../.."

apt_install() { # packages...
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing $* (Debian)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@" >/dev/null
  else
    echo "error: $* missing and cannot be installed here (needs root and apt-get)" >&2
    exit 1
  fi
}

command -v gmsh >/dev/null 2>&1 || apt_install gmsh
command -v python3 >/dev/null 2>&1 || apt_install python3 python3-venv

venv=target/ci-venv
python=$venv/bin/python
if ! "$python" -c "import numpy, meshio, vtk" >/dev/null 2>&1; then
  rm -rf "$venv"
  if ! python3 -m venv "$venv" >/dev/null 2>&1; then
    rm -rf "$venv"
    apt_install python3-venv
    python3 -m venv "$venv"
  fi
  echo "installing numpy, meshio and vtk (PyPI) into $venv"
  "$python" -m pip install --quiet numpy meshio vtk
fi

# The binary: $DENSEPACK_BIN (.ci/run passes the one `cargo test --release` built), else this
# checkout's release build.
if [ -n "${DENSEPACK_BIN:-}" ]; then
  bin=$DENSEPACK_BIN
else
  cargo build --release --quiet
  bin=target/release/densepack
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
check=tests/readers/check_exports.py
checks=$work/checks.tsv
: >"$checks"

# queue_check NAME KIND PACKING.json FILE [options]: one reader check. The checks run at the
# end in one Python process (`check_exports.py --batch`), which imports numpy, meshio and vtk
# once instead of once per check; it names every check that fails.
queue_check() {
  local IFS=$'\t'
  echo "$*" >>"$checks"
}

"$bin" run tests/scenes/export_periodic.toml --out "$work/periodic.json" --quiet
"$bin" run tests/scenes/export_cylinder.toml --out "$work/cylinder.json" --quiet
"$bin" run examples/scenes/walls_8_spheres.toml --out "$work/walls.json" --quiet
"$bin" run tests/scenes/export_ellipsoids.toml --out "$work/ellipsoids.json" --quiet
"$bin" run tests/scenes/export_ellipsoids_walls.toml --out "$work/ellipsoids_walls.json" --quiet
"$bin" run tests/scenes/export_mixture.toml --out "$work/mixture.json" --quiet

# mesh CHECK-NAME PACKING MESH-NAME [export options]: Gmsh meshes the export in the
# background (the meshes are independent; `wait` below collects them), and its check is queued.
meshing=()
mesh() {
  local label=$1 packing=$2 name=$3
  shift 3
  "$bin" export "$work/$packing.json" --format gmsh --out "$work/$name.geo" "$@" >/dev/null
  (gmsh -v 1 -3 -order 2 "$work/$name.geo" -o "$work/$name.msh" >"$work/$name.log" 2>&1 ||
    { cat "$work/$name.log" >&2; echo "FAILED: $label (gmsh)" >&2; exit 1; }) &
  meshing+=("$!")
  queue_check "$label" gmsh "$work/$packing.json" "$work/$name.msh" "$@"
}

mesh "gmsh periodic" periodic periodic
mesh "gmsh periodic with interface shells" periodic periodic_itz --shrink 0.1 --interface 0.05
mesh "gmsh cylinder" cylinder cylinder
mesh "gmsh walls, jammed, shrunk" walls walls --shrink 0.05
# Ellipsoids (exact volumes 4/3 pi abc) in a walled box. Periodic ellipsoid boxes are not
# meshed here: Gmsh 4.8 meshes them, with the right volumes, but the second-order nodes it
# places on the spline curves where an ellipsoid crosses a face differ between opposite faces
# (up to 0.5 % of the box), so the node-for-node periodicity check fails.
mesh "gmsh ellipsoids, walls" ellipsoids_walls ellipsoids_walls
# Spheres and cylinders (exact volumes pi r^2 2|l|) in a periodic cube.
mesh "gmsh sphere + cylinder mixture, periodic" mixture mixture
mesh "gmsh mixture, a group per particle" mixture mixture_particles --labels particle
mesh "gmsh cylinder, a group per particle" cylinder cylinder_particles --labels particle

for packing in periodic cylinder ellipsoids ellipsoids_walls mixture; do
  "$bin" export "$work/$packing.json" --format vtk --out "$work/$packing.vtu" >/dev/null
  queue_check "vtk $packing" vtk "$work/$packing.json" "$work/$packing.vtu"
  if [ "$packing" = periodic ] || [ "$packing" = cylinder ]; then # x,y,z,r: spheres only
    "$bin" export "$work/$packing.json" --format csv --out "$work/$packing.csv" >/dev/null
    queue_check "csv $packing" csv "$work/$packing.json" "$work/$packing.csv"
    "$bin" export "$work/$packing.json" --format xyzd --out "$work/$packing.xyzd" >/dev/null
    queue_check "xyzd $packing" xyzd "$work/$packing.json" "$work/$packing.xyzd"
    "$bin" export "$work/$packing.json" --format lammps --out "$work/$packing.data" >/dev/null
    queue_check "lammps $packing" lammps "$work/$packing.json" "$work/$packing.data"
  fi
  "$bin" export "$work/$packing.json" --format npy --voxels 48 --out "$work/$packing.npy" >/dev/null
  queue_check "npy $packing" npy "$work/$packing.json" "$work/$packing.npy"
  "$bin" export "$work/$packing.json" --format raw --labels particle --voxels 40 --out "$work/$packing.raw" >/dev/null
  queue_check "raw $packing" raw "$work/$packing.json" "$work/$packing.raw"
  "$bin" export "$work/$packing.json" --format npy --partial-volume 3 --voxels 24 --out "$work/$packing.pv.npy" >/dev/null
  queue_check "partial volume $packing" npy "$work/$packing.json" "$work/$packing.pv.npy"
  # vti and abaqus on the grids of the .npy exports above: the same labels.
  "$bin" export "$work/$packing.json" --format vti --voxels 48 --out "$work/$packing.vti" >/dev/null
  queue_check "vti $packing" vti "$work/$packing.json" "$work/$packing.vti" "$work/$packing.npy"
  "$bin" export "$work/$packing.json" --format vti --partial-volume 3 --voxels 24 --out "$work/$packing.pv.vti" >/dev/null
  queue_check "vti partial volume $packing" vti "$work/$packing.json" "$work/$packing.pv.vti" "$work/$packing.pv.npy"
  "$bin" export "$work/$packing.json" --format abaqus --voxels 48 --out "$work/$packing.inp" >/dev/null
  queue_check "abaqus $packing" abaqus "$work/$packing.json" "$work/$packing.inp" "$work/$packing.npy"
  "$bin" export "$work/$packing.json" --format npy --labels particle --voxels 24 --out "$work/$packing.p.npy" >/dev/null
  "$bin" export "$work/$packing.json" --format abaqus --labels particle --voxels 24 --out "$work/$packing.p.inp" >/dev/null
  queue_check "abaqus per particle $packing" abaqus "$work/$packing.json" "$work/$packing.p.inp" "$work/$packing.p.npy"
done

for pid in "${meshing[@]}"; do
  wait "$pid"   # a failed mesh ends the script (set -e)
done
"$python" "$check" --batch "$checks"
