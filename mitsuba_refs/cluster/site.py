"""A reference's render calls on a Dask cluster, merged in call order.

:class:`ClusterSite` is what :func:`mitsuba_refs.reference.split.rendering_on` takes: for
one reference it cuts the ``batch`` method's render calls into tasks
(:func:`mitsuba_refs.reference.split.chunks`), submits them, and hands the calls' block
statistics back **in call order** once each task is done, whatever order they finish in.
The client merges them (:func:`mitsuba_refs.reference.batch.render_moments`), so the
reference is identical, bit for bit, to the serial one.

A worker that dies mid-task costs that task: the scheduler runs it again on another worker
(same calls, same seeds, same blocks). A lost scheduler is
:class:`~mitsuba_refs.cluster.client.ClusterUnavailable`, raised before the reference is
stored.
"""

import contextlib
import os
from concurrent.futures import CancelledError

from ..reference.calls import render_calls
from ..reference.config import ENV_VARIANT
from ..reference.split import chunks, rendering_on
from .client import connect, fault_dir, lost, worker_count

#: Tasks per worker for one reference: a few, so that a slow or killed worker's share is
#: small, but each task loads the scene once (docs/cluster.md, overhead per task).
TASKS_PER_WORKER = 4


class ClusterSite:
    """Render references' calls on the cluster of ``client`` (scheduler ``address``)."""

    def __init__(self, client, address, variant=None, tasks=None):
        self.client = client
        self.address = address
        # scalar_rgb renders are reproducible bit for bit and split per call (batch method).
        self.variant = variant or os.environ.get(ENV_VARIANT) or "scalar_rgb"
        self.tasks = tasks

    def split_for(self, job):
        """``split(calls)`` of :func:`mitsuba_refs.reference.batch.render_moments` for ``job``."""
        job = job._replace(fault_dir=fault_dir())

        def split(calls):
            tasks = self.tasks or TASKS_PER_WORKER * worker_count(self.client)
            runs = chunks(calls, tasks)
            futures = [self.client.submit(render_calls, job, run, pure=False) for run in runs]
            try:
                for future in futures:      # call order, not completion order
                    yield from self._result(future)
            finally:
                self.client.cancel([f for f in futures if not f.done()])
        return split

    def _result(self, future):
        """The future's blocks; a lost scheduler as one clear error."""
        try:
            return future.result()
        except Exception as error:
            if self.client.status not in ("running", "connecting") or _is_lost(error):
                raise lost(self.address, error) from None
            raise


def _is_lost(error) -> bool:
    """True for the errors a client raises when its scheduler went away."""
    from distributed.comm.core import CommClosedError  # Dask: optional, only for --dask
    return isinstance(error, (CancelledError, CommClosedError))


@contextlib.contextmanager
def on_cluster(address, variant=None):
    """References rendered inside the block go to the cluster at ``address`` (``--dask``);
    nothing changes when ``address`` is None."""
    if not address:
        yield None
        return
    with connect(address) as client, rendering_on(ClusterSite(client, address, variant)) as site:
        yield site
