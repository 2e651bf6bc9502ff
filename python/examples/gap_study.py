"""Δd_max against d_min over seeds: a B16 concrete specimen (50 mm walled cube, φ_M = 0.7),
grown to the true grain sizes, then the gap between all grains opened as far as it goes
(`until = { max_gap = true }`, paper 001 Sec. 4.3).

    python python/examples/gap_study.py --out gap-study --seeds 4 [--d-min 2 3 4 6 8]

Writes one ensemble directory per d_min (packings and summary.csv), `gap_study.csv`
(d_min, seeds ok, mean and spread of Δd_max, mean wall seconds) and, with matplotlib,
`gap_study.png`. Runs on a Dask LocalCluster (one worker per core) unless --scheduler names
a running scheduler.
"""

import argparse
import csv
import pathlib
import statistics

import densepack

HERE = pathlib.Path(__file__).resolve().parent
SCENE = HERE.parent.parent / "examples" / "scenes" / "concrete_b16_50mm.toml"


def gap_scene(d_min: float) -> densepack.Scene:
    """The specimen at cut-off `d_min` with a Δd-maximisation stage after the growth."""
    table = densepack.Scene.from_toml(SCENE).with_values({"particles.d_min": d_min}).to_dict()
    table["stage"].append({"growth": "absolute", "rate": 0.01, "until": {"max_gap": True}})
    return densepack.Scene.from_dict(table)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument("--seeds", type=int, default=4, help="seeds 1..N per d_min")
    parser.add_argument("--d-min", type=float, nargs="+", default=[2.0, 3.0, 4.0, 6.0, 8.0])
    parser.add_argument("--scheduler", help="address of a running Dask scheduler")
    args = parser.parse_args()

    from dask.distributed import Client, LocalCluster

    cluster = None
    if args.scheduler:
        client = Client(args.scheduler)
    else:
        cluster = LocalCluster(threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    results = []
    try:
        for d_min in args.d_min:
            rows = densepack.ensemble(
                gap_scene(d_min),
                range(1, args.seeds + 1),
                args.out / f"d_min_{d_min:g}",
                client=client,
            )
            gaps = [r["min_gap"] for r in rows if r["status"] == "ok"]
            seconds = [r["wall_seconds"] for r in rows if r["status"] == "ok"]
            results.append(
                {
                    "d_min": d_min,
                    "seeds_ok": len(gaps),
                    "gap_max_mean": statistics.fmean(gaps) if gaps else float("nan"),
                    "gap_max_spread": (max(gaps) - min(gaps)) if gaps else float("nan"),
                    "wall_seconds_mean": statistics.fmean(seconds) if seconds else float("nan"),
                }
            )
            print(results[-1])
    finally:
        client.close()
        if cluster is not None:
            cluster.close()

    with open(args.out / "gap_study.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(results[0]))
        writer.writeheader()
        writer.writerows(results)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot (the table is gap_study.csv)")
        return
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.errorbar(
        [r["d_min"] for r in results],
        [r["gap_max_mean"] for r in results],
        yerr=[r["gap_max_spread"] / 2 for r in results],
        marker="o",
        capsize=3,
        label="densepack (mean, half spread)",
    )
    ax.plot([r["d_min"] for r in results], [r["d_min"] / 2 for r in results], "k--", label="Δd = d_min / 2")
    ax.set_xlabel("d_min (mm)")
    ax.set_ylabel("Δd_max (mm)")
    ax.set_title("B16, φ_M = 0.7, 50 mm walled cube")
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out / "gap_study.png", dpi=120)


if __name__ == "__main__":
    main()
