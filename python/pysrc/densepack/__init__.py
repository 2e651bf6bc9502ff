"""densepack: dense random packings of hard particles, from Python.

The engine is the densepack Rust library (``densepack._densepack``); this package shows
progress and runs ensembles on Dask. Five lines from a scene to numpy arrays::

    import densepack
    scene = densepack.Scene.from_toml("walls_8_spheres.toml").with_seed(3)
    packing = densepack.run(scene)
    packing.centers, packing.radii        # (N, 3) and (N,) float64
    packing.verify()["ok"]                # the independent overlap check

Lengths are in the scene's unit. ``densepack.ensemble`` runs one realisation per seed on a
Dask cluster (``pip install densepack[dask]``).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any, Callable, Optional, Union

from ._densepack import (
    DensepackError,
    Packing,
    RunFailed,
    Scene,
    __version__,
    _run,
    take,
)
from ._ensemble import ensemble

__all__ = [
    "DensepackError",
    "Packing",
    "RunFailed",
    "Scene",
    "__version__",
    "ensemble",
    "run",
    "take",
]

ProgressCallback = Callable[[str, int, int, dict], None]


def run(
    scene: Union[Scene, str, "os.PathLike[str]"],
    progress: Union[bool, ProgressCallback] = True,
    checkpoint: Optional[Union[str, "os.PathLike[str]"]] = None,
    checkpoint_every: float = 600.0,
) -> Packing:
    """Runs a scene and returns its verified packing.

    ``scene`` is a :class:`Scene` or a TOML file or text. ``progress=True`` shows a tqdm bar
    when tqdm is installed, else a plain status line on stderr; ``False`` shows nothing; a
    callable ``f(kind, stage, stages, record)`` receives ``kind`` "progress" (about four
    times a second) or "stage" (once per finished stage) with a dict ``record``.
    ``checkpoint`` names a file the run writes checkpoints to every ``checkpoint_every``
    seconds; when it exists, the run resumes from it (same packing, bit for bit).

    The run releases the GIL; Ctrl-C stops it within a second and raises
    ``KeyboardInterrupt``. A run that ends without a packing raises :class:`RunFailed`
    carrying the verdict; nothing is written.
    """
    if not isinstance(scene, Scene):
        scene = Scene.from_toml(scene)
    if progress is True:
        callback: Optional[ProgressCallback] = _default_progress()
    elif progress is False or progress is None:
        callback = None
    elif callable(progress):
        callback = progress
    else:
        raise ValueError("progress: True, False or a callable f(kind, stage, stages, record)")
    try:
        return _run(
            scene,
            progress=callback,
            checkpoint=None if checkpoint is None else os.fspath(checkpoint),
            checkpoint_every=checkpoint_every,
        )
    finally:
        close = getattr(callback, "close", None)
        if close is not None:
            close()


class _Line:
    """A status line on stderr, rewritten in place; the fallback without tqdm."""

    def __init__(self) -> None:
        self._shown = False

    def __call__(self, kind: str, stage: int, stages: int, record: dict) -> None:
        if kind == "progress":
            text = (
                f"stage {stage + 1}/{max(stages, 1)}  phi {record['packing_fraction']:.6f}"
                f"  Z {record['reduced_pressure']:.3e}  events {record['events']:,}"
                f"  {record['wall_seconds']:.1f} s"
            )
            sys.stderr.write("\r" + text.ljust(78))
            self._shown = True
        else:
            sys.stderr.write(
                f"\rstage {stage + 1}/{max(stages, 1)}: {record['stop_reason']}  "
                f"phi {record['packing_fraction']:.6f}  Z {record['reduced_pressure']:.3e}  "
                f"{record['wall_seconds']:.1f} s".ljust(78)
                + "\n"
            )
            self._shown = False
        sys.stderr.flush()

    def close(self) -> None:
        if self._shown:
            sys.stderr.write("\n")
            sys.stderr.flush()
            self._shown = False


class _Bar:
    """A tqdm bar over the stages, with phi, Z and events as its postfix."""

    def __init__(self, tqdm: Any) -> None:
        self._tqdm = tqdm
        self._bar: Any = None
        self._started = time.monotonic()

    def __call__(self, kind: str, stage: int, stages: int, record: dict) -> None:
        if self._bar is None:
            self._bar = self._tqdm(total=max(stages, 1), unit="stage", desc="densepack")
        self._bar.set_postfix(
            phi=f"{record['packing_fraction']:.6f}",
            Z=f"{record['reduced_pressure']:.3e}",
            refresh=False,
        )
        if kind == "stage":
            self._bar.update(1)
        else:
            self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _default_progress() -> ProgressCallback:
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return _Line()
    return _Bar(tqdm)
