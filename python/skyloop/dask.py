"""Monte Carlo campaigns on a Dask cluster: chunks of run indices mapped over a
``dask.distributed.Client``, merged in order, summarized by skyloop.

The merged result equals ``skyloop.montecarlo(scenario, seeds)`` on one machine: every run depends
only on its index, and the summary is computed over the runs in the order of ``seeds``.
"""
from __future__ import annotations

from typing import Iterable, Optional, Union

import skyloop as _sk


def _run_chunk(text: str, seeds: list, threads: Optional[int]) -> list:
    """One task on a worker: the runs ``seeds`` of the scenario (TOML text), as run-metrics dicts."""
    return _sk._skyloop._montecarlo(text, list(seeds), threads)["runs"]


def montecarlo(scenario, seeds: Union[None, str, Iterable[int]], client, chunk_size: Optional[int] = None,
               threads_per_task: Optional[int] = 1) -> dict:
    """Runs ``seeds`` of a scenario's ``[monte_carlo]`` study on a Dask cluster.

    ``scenario`` a TOML path or text (read here and shipped as text, so workers need no shared
    file system); ``seeds`` run indices as for :func:`skyloop.montecarlo` (None: all the study's
    runs); ``client`` a ``dask.distributed.Client``; ``chunk_size`` runs per task (default: four
    tasks per worker thread); ``threads_per_task`` threads each task uses (default 1, so a worker's
    threads are its parallelism; None: all cores of the worker's machine).
    Returns the dict of :func:`skyloop.montecarlo`: {seeds, runs, summary}.
    """
    text = _sk.scenario_text(scenario)
    seeds = _sk._seeds(seeds)
    if seeds is None:
        n = _sk._skyloop._study_runs(text)
        if n is None:
            raise _sk.InputError("the scenario has no [monte_carlo] section")
        seeds = list(range(n))
    if not seeds:
        raise _sk.InputError("seeds: at least one run is needed")
    if chunk_size is None:
        slots = sum(client.nthreads().values()) or 1
        chunk_size = max(1, -(-len(seeds) // (4 * slots)))
    chunks = [seeds[i:i + chunk_size] for i in range(0, len(seeds), chunk_size)]
    futures = client.map(_run_chunk, [text] * len(chunks), chunks, [threads_per_task] * len(chunks), pure=False)
    parts = client.gather(futures)
    runs = [r for part in parts for r in part]
    return {"seeds": seeds, "runs": runs, "summary": _sk.summarize(runs)}
