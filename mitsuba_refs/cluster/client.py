"""Connecting to a Dask scheduler, and telling a lost one in one line.

``--dask ADDRESS`` takes what the sweeps of ``experiments/`` take: a scheduler address
(``tcp://host:8786``) or ``local`` for a LocalCluster of single-threaded worker processes on
this machine. An unreachable or lost scheduler is :class:`ClusterUnavailable` (an ``OSError``:
the command line prints it in one line and exits with 2), raised before anything is stored.
"""

import contextlib
import logging
import os

from ..reference.split import ENV_FAULT_DIR

#: Seconds to wait for the scheduler when connecting.
CONNECT_TIMEOUT = 10


class ClusterUnavailable(ConnectionError):
    """The Dask scheduler cannot be reached, or was lost during the run."""


def unreachable(address, error) -> ClusterUnavailable:
    """The error for a scheduler at ``address`` that did not answer (``error``: why)."""
    reason = " ".join(str(error).split()) or type(error).__name__
    return ClusterUnavailable(
        f"cannot reach the Dask scheduler at {address} ({reason}); start one with "
        f"`dask scheduler` and workers with `dask worker {address}` (docs/cluster.md)")


def lost(address, error) -> ClusterUnavailable:
    """The error for a scheduler at ``address`` lost while tasks ran; nothing was stored."""
    reason = " ".join(str(error).split()) or type(error).__name__
    return ClusterUnavailable(
        f"lost the Dask scheduler at {address} ({type(error).__name__}: {reason}); nothing "
        f"was stored: rerun when the scheduler is back (finished references stay cached)")


@contextlib.contextmanager
def connect(address, workers=None):
    """A ``distributed.Client`` of the scheduler at ``address`` (``local``: a LocalCluster of
    ``workers`` single-threaded processes, default 2)."""
    try:
        from distributed import Client, LocalCluster  # Dask: optional, imported only for --dask
    except ImportError:
        raise ClusterUnavailable("--dask needs `pip install dask distributed`") from None
    # distributed logs a lost scheduler with tracebacks on stderr; the command says it in one line.
    for name in ["distributed", *logging.root.manager.loggerDict]:
        if name.startswith("distributed"):
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    cluster = None
    try:
        if address == "local":
            cluster = LocalCluster(n_workers=workers or 2, threads_per_worker=1,
                                   dashboard_address=None, processes=True)
            client = Client(cluster)
        else:
            client = Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as error:
        raise unreachable(address, error) from None
    try:
        yield client
    finally:
        with contextlib.suppress(Exception):   # closing a lost scheduler's client
            client.close(timeout=5)
        if cluster is not None:
            cluster.close()


def worker_count(client) -> int:
    """Workers the scheduler knows now (at least 1)."""
    return max(1, len(client.scheduler_info().get("workers", {})))


def fault_dir():
    """The test hook folder (:data:`mitsuba_refs.reference.split.ENV_FAULT_DIR`), or None."""
    return os.environ.get(ENV_FAULT_DIR) or None
