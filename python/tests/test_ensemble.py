"""Ensembles on a two-worker Dask LocalCluster: distinct verified packings, the summary,
lost workers, resumption."""

import csv
import os
import signal
import threading
import time

import numpy as np
import pytest

import densepack

pytest.importorskip("dask.distributed")


def summary_rows(out):
    with open(out / "summary.csv", newline="") as f:
        return list(csv.DictReader(f))


def test_ensemble_gives_distinct_verified_packings_and_resumes(scenes, tmp_path, dask_client):
    scene = densepack.Scene.from_toml(scenes / "sample_spheres.toml")
    out = tmp_path / "ens"
    rows = densepack.ensemble(scene, [1, 2, 3, 4], out, client=dask_client, progress=False)
    assert [r["seed"] for r in rows] == [1, 2, 3, 4]
    assert all(r["status"] == "ok" for r in rows), rows
    packings = {s: densepack.Packing.load(out / f"seed-{s}.json") for s in [1, 2, 3, 4]}
    for seed, p in packings.items():
        assert p.seed == seed and p.verify()["ok"]
    centers = [p.centers for p in packings.values()]
    assert all(not np.array_equal(a, b) for i, a in enumerate(centers) for b in centers[i + 1:])
    # The rows describe the files: φ and the smallest gap recomputed from each packing.
    for r in rows:
        p = packings[r["seed"]]
        assert r["packing_fraction"] == pytest.approx(p.packing_fraction, rel=1e-12)
        assert r["min_gap"] == p.verify()["min_pair_gap"]
    # The same seed run alone gives the same packing.
    alone = densepack.run(scene.with_seed(3), progress=False)
    assert np.array_equal(alone.centers, packings[3].centers)
    # A rerun after losing one packing runs only that seed.
    (out / "seed-2.json").unlink()
    before = len(summary_rows(out))
    rows = densepack.ensemble(scene, [1, 2, 3, 4], out, client=dask_client, progress=False)
    after = summary_rows(out)
    assert len(after) == before + 1 and after[-1]["seed"] == "2" and after[-1]["status"] == "ok"
    assert (out / "seed-2.json").exists() and all(r["status"] == "ok" for r in rows)


def test_failed_realisations_are_reported_with_their_verdict(scenes, tmp_path, dask_client):
    scene = densepack.Scene.from_toml(scenes / "walls_8_spheres.toml").with_values(
        {"stage.0.until": {"packing_fraction": 0.7}}
    )
    rows = densepack.ensemble(scene, [1, 2], tmp_path, client=dask_client, progress=False)
    assert [r["status"] for r in rows] == ["failed", "failed"]
    assert all("jammed_before_goal" in r["message"] for r in rows)
    assert not list(tmp_path.glob("seed-*.json"))


def test_a_killed_worker_loses_its_realisation_while_the_others_finish(scenes, tmp_path, dask_client):
    # Realisations of about a second each; one worker is killed while it runs one.
    scene = densepack.Scene.from_toml(scenes / "sample_spheres.toml").with_values(
        {"particles.count": 3000, "container.size": [15.0, 15.0, 15.0]}
    )
    pids = dask_client.run(os.getpid)  # worker address -> process id
    victim = sorted(pids.values())[0]

    def kill():
        time.sleep(0.5)
        os.kill(victim, signal.SIGKILL)

    killer = threading.Thread(target=kill)
    killer.start()
    rows = densepack.ensemble(scene, [11, 12, 13, 14], tmp_path, client=dask_client, progress=False)
    killer.join()
    statuses = [r["status"] for r in rows]
    assert "lost" in statuses and "ok" in statuses, rows
    lost = [r for r in rows if r["status"] == "lost"]
    assert all("KilledWorker" in r["message"] for r in lost), lost
    for r in rows:
        assert (tmp_path / f"seed-{r['seed']}.json").exists() == (r["status"] == "ok")
    # A rerun does the lost ones only (the cluster's nanny restarted the worker).
    dask_client.wait_for_workers(2, timeout=60)
    rows = densepack.ensemble(scene, [11, 12, 13, 14], tmp_path, client=dask_client, progress=False)
    assert all(r["status"] == "ok" for r in rows), rows
    assert len(summary_rows(tmp_path)) == 4 + len(lost)
