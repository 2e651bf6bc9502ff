"""The smallest rows of the figure scripts in benches/scripts/, run as a user runs them, with
their exact values checked."""

import csv
import math
import pathlib
import subprocess
import sys

import pytest

import densepack

REPO = pathlib.Path(__file__).resolve().parents[2]

pytest.importorskip("dask.distributed")


def test_jamming_against_n_smallest_rows_meet_the_exact_values(tmp_path, dask_client):
    """Paper 001, Fig. 5 at N ≤ 8 in the walled cube: one sphere and the simple cubic lattice
    jam at π/6, two spheres in opposite corners at (π/3)(√3/(1 + √3))³. At Z = 10¹² the gaps
    are about 10⁻¹² of a diameter, so every protocol must meet the exact values to 10⁻⁶
    (the script's sphere count at N = 4 jams in several ways and has no exact value); the
    `fixed` protocol must not run the slow scene's `[jam]`."""
    out = tmp_path / "fig5"
    subprocess.run(
        [
            sys.executable,
            str(REPO / "benches" / "scripts" / "jamming_vs_n.py"),
            "--out",
            str(out),
            "--seeds",
            "1",
            "--max-n",
            "8",
            "--protocols",
            "fixed,slow,jam",
            "--scheduler",
            dask_client.scheduler_info()["address"],
        ],
        check=True,
        timeout=300,
    )
    with open(out / "jamming_vs_n.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    corners = math.pi / 3 * (math.sqrt(3) / (1 + math.sqrt(3))) ** 3
    exact = {1: math.pi / 6, 2: corners, 8: math.pi / 6}
    checked = 0
    for r in rows:
        n = int(r["n"])
        assert int(r["seeds_ok"]) == 1, r
        if r["boundary"] == "walled" and n in exact:
            assert abs(float(r["phi_mean"]) - exact[n]) < 1e-6, r
            checked += 1
    # Three protocols, N = 1, 2 and 8.
    assert checked == 9, rows
    assert (out / "fixed_walled_1" / "summary.csv").is_file()
    # Each protocol ran its own stages: `[jam]` only under `jam`.
    for protocol, stop in [
        ("fixed", "pressure_reached"),
        ("slow", "pressure_reached"),
        ("jam", "collectively_jammed"),
    ]:
        packing = densepack.Packing.load(out / f"{protocol}_walled_8" / "seed-1.json")
        assert packing.stats["stop_reason"] == stop, protocol
    # The figure is drawn again from the saved table alone, the table read back as numbers.
    replot = tmp_path / "replot"
    done = subprocess.run(
        [
            sys.executable,
            str(REPO / "benches" / "scripts" / "jamming_vs_n.py"),
            "--out",
            str(replot),
            "--replot",
            str(out / "jamming_vs_n.csv"),
        ],
        check=True,
        timeout=60,
        capture_output=True,
        text=True,
    )
    try:
        import matplotlib  # noqa: F401

        assert (replot / "jamming_vs_n.svg").read_text().lstrip().startswith("<?xml")
    except ImportError:
        assert "matplotlib is not installed" in done.stdout
        assert not (replot / "jamming_vs_n.svg").exists()
    sys.path.insert(0, str(REPO / "benches" / "scripts"))
    try:
        import jamming_vs_n
    finally:
        sys.path.pop(0)
    table = jamming_vs_n.read_table(out / "jamming_vs_n.csv")
    assert [(r["protocol"], r["boundary"], r["n"]) for r in table] == [
        (r["protocol"], r["boundary"], int(r["n"])) for r in rows
    ]
    assert all(
        t["phi_mean"] == float(r["phi_mean"]) and isinstance(t["seeds_ok"], int)
        for t, r in zip(table, rows)
    )
