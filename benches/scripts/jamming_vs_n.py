"""Paper 001, Fig. 5: the jammed packing fraction of N equal spheres in a cube of fixed edge,
walled (the paper's set-up) and periodic, against N, over seeds.

    pip install "./python[dask]" matplotlib
    python benches/scripts/jamming_vs_n.py --out fig5 [--seeds 3] [--max-n 1000]
    python benches/scripts/jamming_vs_n.py --out fig5-large --protocols fixed --max-n 100000

Each point is an ensemble (`densepack.ensemble`, one realisation per seed on a Dask
LocalCluster, or on --scheduler) of the scene: N spheres seeded by RSA at φ = 0.3 as in the
paper (0.1 below N = 216: two spheres jam at 0.267, and RSA cannot place a few large spheres
at 0.3; at N = 125 in the walled cube one seed in three gets stuck), then grown until the reduced pressure reaches 10¹², with one of two protocols —

- `fixed`: one relative growth rate, 0.05 (the default scene's; the paper grows "with the
  same growth rate until the simulation aborts");
- `slow`: the stages of `examples/scenes/mono_periodic_jam_slow.toml` (a rate that falls
  with the pressure to Z = 10⁹, then 0.0005), which leave a near-isostatic backbone;
- `jam`: the same stages, then the scene's `[jam]` (sequential linear programming): a
  collectively jammed packing (seconds per program at N = 10³, minutes at 10⁴).

Writes `DIR/<protocol>_<boundary>_<N>/` (packings and summary.csv), `DIR/jamming_vs_n.csv`
(protocol, boundary, N, seeds ok, φ mean/min/max, exact value where known, mean wall
seconds per run) and, with matplotlib, `DIR/jamming_vs_n.svg` (`--replot CSV ...` draws it
again from saved tables without running anything). Exact values: N = 1 and
N = 8 (simple cubic) in the walled cube jam at π/6; N = 2 in opposite corners at
(π/3)(√3/(1 + √3))³ ≈ 0.2668 (the paper's "drop"); large N approaches φ_MRJ ≈ 0.64 from
below in the walled cube (the wall layer is looser) and at about 0.64 in the periodic box.
A periodic box must be wider than two diameters: the periodic series starts where the scene
is valid (the script prints the cases it skips and why).
"""

import argparse
import csv
import math
import pathlib
import statistics

import densepack

REPO = pathlib.Path(__file__).resolve().parents[2]
SLOW = REPO / "examples" / "scenes" / "mono_periodic_jam_slow.toml"
EDGE = 10.0
COUNTS = [1, 2, 3, 4, 8, 16, 27, 64, 125, 216, 512, 1000, 4096, 10_000, 100_000]

# The protocols and their plot markers.
PROTOCOLS = {"fixed": "o", "slow": "s", "jam": "^"}

EXACT_WALLED = {
    1: math.pi / 6,
    2: math.pi / 3 * (math.sqrt(3) / (1 + math.sqrt(3))) ** 3,
    8: math.pi / 6,
}


def scene(protocol: str, periodic: bool, n: int) -> densepack.Scene:
    """N spheres in the cube of edge EDGE under `protocol`."""
    table = densepack.Scene.from_toml(SLOW).to_dict()
    if protocol != "jam":
        table.pop("jam", None)
    table["container"]["size"] = [EDGE] * 3
    table["container"]["periodic"] = [periodic] * 3
    table["particles"]["count"] = n
    table["particles"]["packing_fraction"] = 0.3 if n >= 216 else 0.1
    if protocol == "fixed":
        table["stage"] = [
            {
                "growth": "relative",
                "rate": 0.05,
                "until": {"reduced_pressure": 1e12},
                "max_wall_seconds": 3600,
            }
        ]
    return densepack.Scene.from_dict(table)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument("--seeds", type=int, default=3, help="seeds 1..S per point")
    parser.add_argument("--max-n", type=int, default=1000, help="largest N (≤ 100 000)")
    parser.add_argument(
        "--protocols",
        default="fixed,slow",
        help="comma-separated: fixed, slow, jam (the slow finish takes about 7 min at N = 10⁴, "
        "jam 15 min more)",
    )
    parser.add_argument("--scheduler", help="address of a running Dask scheduler")
    parser.add_argument(
        "--replot",
        type=pathlib.Path,
        nargs="+",
        metavar="CSV",
        help="run nothing: draw DIR/jamming_vs_n.svg from the rows of these jamming_vs_n.csv "
        "files (e.g. of runs with different --protocols)",
    )
    args = parser.parse_args()
    if args.replot:
        args.out.mkdir(parents=True, exist_ok=True)
        plot([r for path in args.replot for r in read_table(path)], args.out / "jamming_vs_n.svg")
        return
    protocols = args.protocols.split(",")
    if not protocols or any(p not in PROTOCOLS for p in protocols):
        parser.error(f"--protocols: {args.protocols!r}; allowed: fixed, slow, jam, comma-separated")
    if not 1 <= args.max_n <= COUNTS[-1]:
        parser.error(f"--max-n: {args.max_n} is outside [1, {COUNTS[-1]}]")

    from dask.distributed import Client, LocalCluster

    cluster = None
    if args.scheduler:
        client = Client(args.scheduler)
    else:
        cluster = LocalCluster(threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    results = []
    try:
        for protocol in protocols:
            for boundary in ["walled", "periodic"]:
                for n in [c for c in COUNTS if c <= args.max_n]:
                    try:
                        this = scene(protocol, boundary == "periodic", n)
                    except ValueError as e:
                        print(f"{protocol:5} {boundary:8} N {n:6}: skipped: {e}", flush=True)
                        continue
                    rows = densepack.ensemble(
                        this,
                        range(1, args.seeds + 1),
                        args.out / f"{protocol}_{boundary}_{n}",
                        client=client,
                        progress=False,
                    )
                    phis = [r["packing_fraction"] for r in rows if r["status"] == "ok"]
                    seconds = [r["wall_seconds"] for r in rows if r["status"] == "ok"]
                    exact = EXACT_WALLED.get(n) if boundary == "walled" else None
                    results.append(
                        {
                            "protocol": protocol,
                            "boundary": boundary,
                            "n": n,
                            "seeds_ok": len(phis),
                            "phi_mean": statistics.fmean(phis) if phis else math.nan,
                            "phi_min": min(phis, default=math.nan),
                            "phi_max": max(phis, default=math.nan),
                            "phi_exact": "" if exact is None else exact,
                            "wall_seconds_mean": statistics.fmean(seconds) if seconds else math.nan,
                        }
                    )
                    r = results[-1]
                    print(
                        f"{protocol:5} {boundary:8} N {n:6}: φ {r['phi_mean']:.4f} "
                        f"[{r['phi_min']:.4f}, {r['phi_max']:.4f}] ({r['seeds_ok']} ok)"
                        + (f", exact {exact:.4f}" if exact is not None else ""),
                        flush=True,
                    )
    finally:
        client.close()
        if cluster is not None:
            cluster.close()

    with open(args.out / "jamming_vs_n.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(results[0]))
        writer.writeheader()
        writer.writerows(results)
    plot(results, args.out / "jamming_vs_n.svg")


def read_table(path: pathlib.Path) -> list[dict]:
    """The rows of a `jamming_vs_n.csv` written by this script, with numbers as numbers."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        r["n"] = int(r["n"])
        r["seeds_ok"] = int(r["seeds_ok"])
        for key in ["phi_mean", "phi_min", "phi_max", "wall_seconds_mean"]:
            r[key] = float(r[key])
    return rows


def plot(results: list[dict], path: pathlib.Path) -> None:
    """Draws φ against N, a series per protocol and boundary, to the SVG `path` (nothing
    without matplotlib)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (the table is jamming_vs_n.csv)")
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for protocol, marker in PROTOCOLS.items():
        for boundary, colour in [("walled", "C0"), ("periodic", "C1")]:
            rs = [r for r in results if r["protocol"] == protocol and r["boundary"] == boundary]
            if not rs:
                continue
            ax.errorbar(
                [r["n"] for r in rs],
                [r["phi_mean"] for r in rs],
                yerr=[
                    [r["phi_mean"] - r["phi_min"] for r in rs],
                    [r["phi_max"] - r["phi_mean"] for r in rs],
                ],
                marker=marker,
                color=colour,
                linestyle=":" if protocol == "fixed" else "-",
                capsize=2,
                label=f"{boundary}, {protocol}",
            )
    ax.axhline(0.64, color="k", linestyle="--", linewidth=0.8, label="φ_MRJ ≈ 0.64")
    ax.axhline(math.pi / 6, color="grey", linestyle=":", linewidth=0.8, label="π/6")
    ax.set_xscale("log")
    ax.set_xlabel("N")
    ax.set_ylabel("φ at Z = 10¹²")
    ax.set_title("Paper 001, Fig. 5: jamming of N equal spheres")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)


if __name__ == "__main__":
    main()
