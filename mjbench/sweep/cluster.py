"""Dask: the scheduler address checked, a connection that answers within seconds, chunks
re-run when a worker dies, the scenario shipped to the workers."""
from __future__ import annotations


from .. import environment, outputs
from ..errors import MjbenchError, ParameterError, RunFailed
from .chunks import run_chunk


def check_scheduler(address: str) -> str:
    """A Dask scheduler address, checked for its form: ``tcp://HOST:PORT`` (also tls, ws, wss,
    ucx, inproc; a bare ``HOST:PORT`` means tcp)."""
    from urllib.parse import urlsplit

    text = address.strip()
    full = text if "://" in text else f"tcp://{text}"
    try:
        u = urlsplit(full)
        port = u.port
    except ValueError:
        port, u = None, None
    ok = u is not None and (u.scheme == "inproc" or (u.scheme in ("tcp", "tls", "ws", "wss", "ucx") and u.hostname
                                                       and port is not None and 0 < port < 65536 and u.path in ("", "/")))
    if not ok:
        raise ParameterError(f"--scheduler {address!r}: not a Dask scheduler address; expected tcp://HOST:PORT, e.g. "
                             f"tcp://127.0.0.1:8786 (start one with `dask scheduler`)")
    return full


#: seconds a sweep waits for a Dask scheduler to answer before giving up (``MJBENCH_DASK_TIMEOUT``)
CONNECT_TIMEOUT = 5.0


def connect(address: str):
    """A ``dask.distributed.Client`` of ``address``, or ONE error within :data:`CONNECT_TIMEOUT` s."""
    from dask.distributed import Client

    full = check_scheduler(address)
    timeout = environment.dask_timeout(CONNECT_TIMEOUT)  # (checked: finite seconds > 0, else an error naming it)
    try:
        return Client(full, timeout=timeout)
    except (OSError, TimeoutError) as e:
        raise ParameterError(f"--scheduler {address}: no Dask scheduler answered within {timeout:g} s "
                             f"({type(e).__name__}: {str(e).splitlines()[0] if str(e) else 'no answer'}); check the "
                             f"address and that `dask scheduler` runs there") from None
    except ValueError as e:
        raise ParameterError(f"--scheduler {address!r}: {e}") from None


#: times Dask re-runs a chunk whose worker died or raised (then the sweep stops cleanly)
DASK_RETRIES = 2

#: seconds a sweep waits for its cluster to have a worker again (``MJBENCH_DASK_TIMEOUT`` overrides)
WORKER_TIMEOUT = 30.0

#: seconds between two looks at the cluster while chunks are pending
POLL = 0.5


class ClusterLost(RunFailed):
    """The Dask cluster had no worker (or no scheduler) for longer than the stated timeout."""


def _workers(client) -> int | None:
    """Number of workers the scheduler has, None if the scheduler does not answer."""
    try:
        return len(client.nthreads())
    except Exception:  # noqa: BLE001 - a scheduler gone away: comm errors, timeouts
        return None


def _run_on_dask(client, scn, chunks, keys, st, nthread, collect, table, nrows, ndone):
    """Submit every chunk (``DASK_RETRIES`` retries each: a chunk whose worker is lost runs again
    elsewhere) and collect them as they complete.  If the cluster still loses a chunk, or has no
    worker (or no answering scheduler) for :data:`WORKER_TIMEOUT` s (``MJBENCH_DASK_TIMEOUT``), stop
    cleanly: ONE error saying how many rows are saved and that the same command resumes."""
    import time

    from dask.distributed import wait

    limit = environment.dask_timeout(WORKER_TIMEOUT)
    scn_f = ship_scenario(client, scn)
    futs = [client.submit(run_chunk, scn_f, ch, keys, st, nthread, pure=False, retries=DASK_RETRIES)
            for ch in chunks]
    saved = ndone

    def stop(why):
        for f in futs:
            f.cancel()
        if saved:
            return ClusterLost(f"{why}; {saved} of {nrows} rows are saved in {table}: run the same command again to "
                               f"resume")
        return ClusterLost(f"{why}; no row was saved: run the same command again once the cluster has workers")

    pending, idle = set(futs), None
    try:
        while pending:
            try:
                done, pending = wait(pending, timeout=POLL, return_when="FIRST_COMPLETED")
            except TimeoutError:  # (dask.distributed.TimeoutError is the built-in one)
                done = set()
            for fut in done:
                res = fut.result()
                collect(res)
                saved += len(res)
            if done:
                idle = None
                continue
            n = _workers(client)
            if n:
                idle = None
            elif idle is None:
                idle = time.monotonic()
            elif time.monotonic() - idle > limit:
                what = "no Dask scheduler answered" if n is None else "the Dask cluster had no worker"
                raise stop(f"{what} for {limit:g} s (MJBENCH_DASK_TIMEOUT) with {len(pending)} chunk(s) of the sweep "
                           f"pending")
    except (MjbenchError, KeyboardInterrupt):
        raise
    except Exception as e:  # noqa: BLE001 - the cluster's failures: lost workers, cancelled futures, comms
        first = (str(e).splitlines() or [""])[0][:200]
        raise stop(f"the Dask cluster lost a chunk of the sweep ({type(e).__name__}: {first}) after {DASK_RETRIES} "
                   f"retries") from None


def ship_scenario(client, scn):
    """The scenario on the cluster as the result of ONE task whose input (the scenario itself) is
    held in the task graph by the scheduler, under a key of its own
    (``mjbench-scenario-<content hash>-<random>``).  Unlike scattered data, a task result lost with
    its worker is recomputed by the scheduler, so a worker killed mid-sweep does not cancel the
    chunks that need the scenario (``FutureCancelledError ... lost dependencies``).  The random
    part keeps two clients of one scheduler from sharing the key (see :func:`scatter_scenario`)."""
    import hashlib
    import uuid

    digest = hashlib.sha256(outputs.dumps(scn.resolved(), sort_keys=True, indent=None).encode()).hexdigest()[:16]
    key = f"mjbench-scenario-{digest}-{uuid.uuid4().hex[:12]}"
    return client.submit(_identity, scn, key=key, pure=False, retries=DASK_RETRIES)


def _identity(x):
    return x


def scatter_scenario(client, scn):
    """Ship the scenario to the cluster as ONE object under a key of its own:
    ``mjbench-scenario-<content hash>-<random>``.  (``client.scatter(dict)`` would make one future
    per top-level key — "drive", "modes", ... — which another client on the same scheduler
    scattering its own scenario replaces: its tasks then read the other machine, or lose their
    inputs when it is released.)  The random part keeps two clients from sharing a key."""
    import hashlib
    import uuid

    digest = hashlib.sha256(outputs.dumps(scn.resolved(), sort_keys=True, indent=None).encode()).hexdigest()[:16]
    key = f"mjbench-scenario-{digest}-{uuid.uuid4().hex[:12]}"
    return client.scatter({key: scn}, broadcast=True)[key]
