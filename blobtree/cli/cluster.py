"""``--scheduler`` and ``--dask-workers``: the Dask cluster a command runs on, if any."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any

import click


def cluster_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """Add ``--scheduler`` and ``--dask-workers`` to a command."""
    command = click.option(
        "--dask-workers", type=click.IntRange(min=1),
        help="Start a local Dask cluster of N single-threaded worker processes.")(command)
    return click.option(
        "--scheduler", metavar="tcp://HOST:PORT",
        help="Run on the Dask cluster of this scheduler (pip install 'blobtree[dask]').")(command)


@contextlib.contextmanager
def cluster(scheduler: str | None, workers: int | None, quiet: bool = False) -> Iterator[Any]:
    """A ``distributed.Client`` for the options given (None: the local engine); prints the
    cluster used unless ``quiet``."""
    if scheduler is None and workers is None:
        yield None
        return
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise click.ClickException("--scheduler and --dask-workers need the optional extra: "
                                   "pip install 'blobtree[dask]'") from None
    from ..distributed import connect, describe

    with connect(scheduler, workers) as client:
        if not quiet:
            click.echo(describe(client), err=True)
        yield client
