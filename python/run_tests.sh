#!/usr/bin/env bash
# Builds and installs the Python package the way a user does (`pip install "./python[test]"`,
# maturin through PEP 517) into a fresh virtual environment, checks the hand-written type
# stubs against the module (mypy.stubtest), and runs the pytest suite from outside the tree
# against the installed package. Called by .ci/run after the Rust tests (whose release build
# provides the `densepack` binary the tests compare with).
#
# Everything comes from PyPI (maturin, numpy, dask[distributed], pytest, mypy) into
# target/py-venv, recreated on every run so that the install path is the one users take.
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/py-venv
rm -rf "$venv"
if ! python3 -m venv "$venv" >/dev/null 2>&1; then
  rm -rf "$venv"
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends python3-venv >/dev/null
    python3 -m venv "$venv"
  else
    echo "error: python3 -m venv failed (install python3-venv)" >&2
    exit 1
  fi
fi
python=$PWD/$venv/bin/python
"$python" -m pip install --quiet --upgrade pip
echo "pip install ./python[test] (builds the extension with maturin)"
"$python" -m pip install --quiet "./python[test]" mypy
# The CLI the tests compare with: $DENSEPACK_BIN (.ci/run passes the one `cargo test
# --release` built), else this checkout's release build.
if [ -z "${DENSEPACK_BIN:-}" ]; then
  cargo build --release --quiet
  DENSEPACK_BIN=$PWD/target/release/densepack
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"   # outside the tree: `import densepack` is the installed package
"$python" -m mypy.stubtest densepack._densepack
DENSEPACK_CLI="$DENSEPACK_BIN" \
  "$python" -m pytest -q -p no:cacheprovider "$OLDPWD/python/tests"
