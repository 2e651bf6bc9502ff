"""Fixtures of the Python package's tests: the repository, the CLI binary, a Dask cluster."""

import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
SCENES = REPO / "examples" / "scenes"


@pytest.fixture(scope="session")
def scenes() -> pathlib.Path:
    return SCENES


@pytest.fixture(scope="session")
def cli() -> str:
    """The `densepack` binary of this checkout, to compare the package with the CLI:
    $DENSEPACK_CLI, else target/release/densepack. CI sets DENSEPACK_CLI; elsewhere a missing
    binary skips the comparisons (build it with `cargo build --release`)."""
    path = os.environ.get("DENSEPACK_CLI") or str(REPO / "target" / "release" / "densepack")
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        if os.environ.get("DENSEPACK_CLI"):
            pytest.fail(f"DENSEPACK_CLI={path} is not an executable")
        pytest.skip("no densepack binary: cargo build --release, or set DENSEPACK_CLI")
    return path


@pytest.fixture(scope="session")
def dask_client():
    """A LocalCluster of two single-threaded worker processes; a worker that dies fails its
    task at once (allowed-failures 0) so that the tests see lost realisations."""
    distributed = pytest.importorskip("dask.distributed")
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        cluster = distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        )
        client = distributed.Client(cluster)
        try:
            yield client
        finally:
            client.close()
            cluster.close()
