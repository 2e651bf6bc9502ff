"""Ensembles on Dask: one realisation per seed, one task each.

The directory layout, the summary file and the resume rule are the library's
(``densepack ensemble`` on the command line writes the same): ``DIR/seed-<seed>.json`` per
realisation and ``DIR/summary.csv`` with one row per finished realisation. This module only
submits the tasks and records their rows as they finish.
"""

from __future__ import annotations

import os
import sys
import uuid
from typing import Any, Iterable, List, Optional, Union

from . import _densepack
from ._densepack import Scene


def _realise(seed: int, scene: Scene, out: str) -> dict:
    """One realisation on a worker: runs, verifies, writes ``seed-<seed>.json``, returns its
    summary row (a failed run returns a ``failed`` row with the verdict and writes nothing)."""
    return _densepack._run_realisation(scene, seed, out)


def ensemble(
    scene: Union[Scene, str, "os.PathLike[str]"],
    seeds: Iterable[int],
    out: Union[str, "os.PathLike[str]"],
    client: Any = None,
    *,
    retries: int = 0,
    progress: bool = True,
) -> List[dict]:
    """Runs one realisation of ``scene`` per seed on Dask and returns their summary rows.

    ``client`` is any ``dask.distributed.Client`` (a ``LocalCluster``, a
    ``dask_jobqueue.SLURMCluster``, ...). Without one, a ``LocalCluster`` with one
    single-threaded worker process per core (the kernel is single-threaded) is started and
    closed afterwards.

    ``out`` receives one packing per seed (``seed-<seed>.json``) and ``summary.csv`` (seed,
    status, packing fraction, min gap, reduced pressure, events, wall seconds, message),
    one row appended as each realisation finishes. Status ``ok``; ``failed`` when the run
    ended with a verdict and no packing (deterministic for its seed); ``lost`` when the
    task never reported (its worker was killed, the cluster went away). A rerun skips seeds
    already ``ok`` (with their packing on disk) or ``failed``, and runs the others.
    ``retries`` re-runs tasks that raised; Dask itself reschedules a task whose worker
    died, up to ``distributed.scheduler.allowed-failures`` times.

    Returns the rows of ``seeds`` as ``summary.csv`` holds them at the end, sorted by seed.
    """
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise ImportError(
            "densepack.ensemble needs Dask: pip install 'densepack[dask]'"
        ) from e
    if not isinstance(scene, Scene):
        scene = Scene.from_toml(scene)
    seeds = [_seed(s) for s in seeds]
    if len(set(seeds)) != len(seeds):
        raise ValueError("seeds: every seed must appear once")
    out = os.fspath(out)
    os.makedirs(out, exist_ok=True)
    todo = _densepack._seeds_to_run(out, seeds)
    cluster = None
    if client is None and todo:
        workers = max(1, min(os.cpu_count() or 1, len(todo)))
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
        )
        client = Client(cluster)
    futures: list = []
    try:
        if todo:
            run_id = uuid.uuid4().hex[:8]
            futures = client.map(
                _realise,
                todo,
                scene=scene,
                out=out,
                key=[f"densepack-{run_id}-seed-{s}" for s in todo],
                pure=False,
                retries=retries,
            )
            seed_of = {f.key: s for f, s in zip(futures, todo)}
            done = 0
            for future in as_completed(futures):
                if future.status == "finished":
                    row = future.result()
                else:
                    error = future.exception()
                    row = {
                        "seed": seed_of[future.key],
                        "status": "lost",
                        "message": f"{type(error).__name__}: {error}",
                    }
                _densepack._append_summary(out, row)
                future.release()
                done += 1
                if progress:
                    _report(row, done, len(todo))
    except KeyboardInterrupt:
        if futures:
            client.cancel(futures)
        raise
    finally:
        if cluster is not None:
            client.close()
            cluster.close()
    wanted = set(seeds)
    rows = [r for r in _densepack._read_summary(out) if r["seed"] in wanted]
    return sorted(rows, key=lambda r: r["seed"])


def _seed(s: Any) -> int:
    if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s < 2**64:
        raise ValueError(f"seeds: {s!r} is not an integer in [0, 2^64)")
    return int(s)


def _report(row: dict, done: int, total: int) -> None:
    status = row.get("status")
    if status == "ok":
        what = (
            f"phi {row['packing_fraction']:.6f}  min gap {row['min_gap']:.3e}"
            f"  {row['wall_seconds']:.1f} s"
        )
    else:
        what = row.get("message", "")
    sys.stderr.write(f"[{done}/{total}] seed {row['seed']}: {status}  {what}\n")
    sys.stderr.flush()
