"""Where many independent runs execute: this process, local worker processes, or a Dask cluster.

``nhsim montecarlo``, ``nhsim simulate --all`` and ``nhsim regress`` hand their runs to one
:class:`Executor`, chosen by ``--jobs J`` / ``--scheduler ADDRESS`` (:func:`make_executor`):

- ``--jobs 1``: a plain loop in this process (no Dask, nothing to start);
- ``--jobs J`` (J > 1): a Dask ``LocalCluster`` of J single-threaded worker processes, started here
  and closed when the executor closes (at most :data:`JOBS_PER_CORE` per core: :func:`worker_count`);
  its workers leave Ctrl-C to this process, and an interrupted close is quiet (:meth:`DaskExecutor.close`);
- ``--scheduler tcp://host:8786``: an existing Dask cluster (``dask scheduler`` and ``dask worker``
  on any machines that have nhsim installed), with no other change. Workers that cannot import nhsim are
  refused with one line (:class:`~planning.errors.DependencyError`); while no worker is connected the runs
  wait for one, and the wait is said once (``notify``), not ended: workers may be started after the command.

Runs are submitted at once and their results yielded as they finish (``as_completed``), each
paired with its item, so the caller can store every result the moment it exists. Runs are pure
functions of their item (and of one shared value, sent to each worker once): a worker that dies
mid-run has its runs executed again elsewhere by the scheduler, and :attr:`Executor.retries` counts
them (batches of runs that were on a worker when it died).
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import struct
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from planning.core.checks import check_number
from planning.errors import ConfigError, DependencyError, SimulationError, option, options

T = TypeVar("T")
R = TypeVar("R")

#: Batches of runs per worker process (see :meth:`DaskExecutor.map_unordered`).
BATCHES_PER_WORKER = 4
#: Running here instead of on a cluster, as messages name it (:func:`planning.errors.option`).
_LOCAL = option("jobs", "J", python="jobs=J")
#: Local worker processes ``--jobs`` may start per core (:func:`max_jobs`).
JOBS_PER_CORE = 4
#: Seconds to reach a scheduler before giving up.
CONNECT_TIMEOUT_S = 10
#: Largest first message a Dask scheduler is taken to greet with [bytes] (its handshake is ~1 kB).
MAX_GREETING_BYTES = 1 << 20
#: Seconds a cluster may have no worker, runs waiting, before the wait is said (a worker restarting is quiet).
NO_WORKER_S = 5.0
#: Seconds between two looks at a cluster's workers while runs wait.
WORKER_CHECK_S = 1.0
#: The local cluster's scheduler serves no dashboard. Its HTTP server (health, metrics) always starts: on
#: ``dashboard_address=None`` Dask binds it to port 8787, warning "Port 8787 is already in use" (and taking
#: another) when something holds that port; here it takes a free port of the loopback interface.
LOCAL_SCHEDULER = {"dashboard_address": "127.0.0.1:0", "scheduler_kwargs": {"dashboard": False}}


def _warn(message: str) -> None:
    """The default ``notify``: a library's warning, on stderr when logging is not set up."""
    logging.getLogger("nhsim").warning("nhsim: %s", message)


def default_jobs() -> int:
    """Worker processes by default: one per core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


class Executor:
    """Runs ``fn(shared, item)`` for many items: the serial base class (``--jobs 1``).

    Attributes:
        retries: Runs executed again because their worker died (always 0 here).
        workers: Worker processes (1: this process).
        where: A short description for messages ("this process", "2 local workers", the address).
    """

    retries = 0
    workers = 1
    where = "this process"

    def map_unordered(self, fn: Callable[[Any, T], R], items: Sequence[T], shared: Any = None) -> Iterator[tuple[T, R]]:
        """Yield ``(item, fn(shared, item))`` for every item, in the order they finish."""
        for item in items:
            yield item, fn(shared, item)

    def preload(self, *modules: str) -> None:
        """Import ``modules`` where the runs execute, before timing or running them (nothing to do here:
        the caller imports them)."""

    def close(self, abandon: bool = False) -> None:
        """Release workers and connections (nothing for the serial executor).

        Args:
            abandon: The runs still going are not wanted (an interrupt): stop them at once.
        """

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        self.close(abandon=kind is not None)  # an interrupt, or a run's error: the runs still going are not wanted


def _run_batch(fn: Callable[[Any, T], R], shared: Any, batch: list[T]) -> list[R]:
    """One task: ``fn(shared, item)`` for each item of a batch, in order."""
    return [fn(shared, item) for item in batch]


def _suspicious(dask_scheduler: Any, keys: list[str]) -> int:  # pragma: no cover - runs on the scheduler
    """Runs on the scheduler: how many times the tasks ``keys`` were on a worker that died."""
    return sum(ts.suspicious for key in keys if (ts := dask_scheduler.tasks.get(key)) is not None)


class DaskExecutor(Executor):
    """Runs on Dask distributed: a local cluster of ``jobs`` processes, or the cluster at ``address``.

    Args:
        jobs: Worker processes of a local cluster (ignored with an address).
        address: A running scheduler, e.g. ``tcp://host:8786``.
        notify: Told, in one line, what the user should hear of while runs wait: a cluster without a
            worker for :data:`NO_WORKER_S` seconds, and a worker connected after that (default: a warning
            of the ``nhsim`` logger).
        kept: What an interrupt keeps, said with the wait (e.g. "finished runs are kept").

    Raises:
        DependencyError: Dask distributed is not installed.
        ConfigError: The scheduler cannot be reached within :data:`CONNECT_TIMEOUT_S` seconds.
    """

    def __init__(
        self,
        jobs: int = 2,
        address: str | None = None,
        *,
        notify: Callable[[str], None] | None = None,
        kept: str = "",
    ) -> None:
        try:
            from dask.distributed import Client
        except ImportError as exc:  # pragma: no cover - a dependency of the project
            raise DependencyError("Dask distributed is missing: pip install 'dask[distributed]'") from exc
        _drop_cancel_reports()
        self._cluster: Any = None
        self._client: Any = None
        self._notify = notify or _warn
        self._kept = kept
        if address is not None:
            check_scheduler(address, CONNECT_TIMEOUT_S, self._notify)
            try:
                self._client = Client(address, timeout=CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError) as exc:
                raise ConfigError(
                    f"cannot reach the Dask scheduler at {address} within {CONNECT_TIMEOUT_S} s ({exc}); start one "
                    f"with 'dask scheduler' and workers with 'dask worker ADDRESS', or run here with {_LOCAL}"
                ) from exc
            self.where = address
        else:
            self._start_local(jobs)
            self.where = f"{jobs} local worker processes"
        self.workers = max(1, len(self._client.scheduler_info().get("workers", {})))

    def _start_local(self, jobs: int) -> None:
        """Start a local cluster of ``jobs`` worker processes that leave Ctrl-C to this process.

        A terminal's Ctrl-C reaches every process of the command; a worker that took it printed its
        traceback beside the command's "interrupted". The cluster is made with SIGINT blocked in the
        thread that makes it, so its event loop's thread, and every worker process that thread starts
        (restarts too), keep it blocked: only this process acts on it, and closes them. The cluster
        starts without workers (an interrupt is held for that moment, so the cluster is never left
        half made), then the workers are asked for and waited for: an interrupt then closes them.
        """
        from multiprocessing import resource_tracker

        from dask.distributed import Client, LocalCluster

        from planning.signals import sigint_blocked, signals_held

        # started first, here: starting it unblocks SIGINT in the thread that starts it (it blocks the
        # signal only for its own start), which would otherwise be the one starting the first worker
        resource_tracker.ensure_running()
        with signals_held(), sigint_blocked():
            self._cluster = LocalCluster(
                n_workers=0,
                threads_per_worker=1,
                processes=True,
                silence_logs=logging.ERROR,
                memory_limit=1.0 / jobs,  # each worker's share, as LocalCluster(n_workers=jobs) gives it
                **LOCAL_SCHEDULER,
            )
        try:
            self._client = Client(self._cluster)
            self._cluster.scale(jobs)
            self._client.wait_for_workers(jobs)
        except BaseException:
            self.close(abandon=True)
            raise

    def map_unordered(self, fn: Callable[[Any, T], R], items: Sequence[T], shared: Any = None) -> Iterator[tuple[T, R]]:
        """Submit every item, then yield ``(item, result)`` as each finishes; an error in a run is raised here.

        Items go in batches of about a quarter of an even share per worker (:data:`BATCHES_PER_WORKER`
        batches each), so the scheduler's cost per task is paid once per batch while the last batches
        still even out the workers' loads; a batch's results are yielded as soon as it is done. On a
        cluster of the user's, a wait without any worker is said (:meth:`_watch_workers`).
        """
        from dask.distributed import as_completed

        client = self._client
        if not items:
            return
        size = max(1, len(items) // (BATCHES_PER_WORKER * self.workers))
        batches = [list(items[i : i + size]) for i in range(0, len(items), size)]
        # ``shared`` (a spec, baselines: small) travels inside each of the few batch tasks rather than
        # scattered once: scattered data held by a worker that dies is lost with it (a worker that
        # joined after the scatter holds none), and every task needing it is cancelled, not retried
        futures = [client.submit(_run_batch, fn, shared, batch, pure=False) for batch in batches]
        batch_of = {f.key: batch for f, batch in zip(futures, batches, strict=True)}
        try:
            with self._watching():
                for future in as_completed(futures):
                    yield from zip(batch_of[future.key], self._result(future), strict=True)
            self.retries += int(client.run_on_scheduler(_suspicious, keys=list(batch_of)))
        finally:
            client.cancel(futures)

    def _result(self, future: Any) -> Any:
        """A batch's results; a batch on which too many workers died ends the runs in one line, not Dask's traceback.

        Raises:
            SimulationError: The batch was on as many workers as the scheduler allows to die with it
                (``distributed.scheduler.allowed-failures``, default 3) and each died: out of memory, killed, or a
                worker whose environment lacks nhsim (it dies on its first run: a worker is checked when the runs
                start, not when it joins later).
        """
        from dask.distributed import KilledWorker

        try:
            return future.result()
        except KilledWorker as exc:
            kept = f"; {self._kept}" if self._kept else ""
            n = exc.allowed_failures + 1
            raise SimulationError(
                f"{n} worker{'s' * (n > 1)} at {self.where} died running the same runs (Dask's "
                f"KilledWorker; the last, {exc.last_worker.address}): a worker out of memory or killed, or one started "
                "where nhsim is not installed (a worker is checked when the runs start, not when it joins later): see "
                f"the workers' logs{kept}"
            ) from exc

    def preload(self, *modules: str) -> None:
        """Import ``modules`` on every worker now (MuJoCo, numba's compiled kernels), so a worker's
        first run is not slowed by its imports (a cluster without workers yet: nothing to do).

        Raises:
            DependencyError: A worker cannot import one of them (nhsim is not installed where it runs), naming
                the workers, the import's error and the fix, in one line.
        """
        import importlib

        for name in modules:
            if self._cluster is None:  # the scheduler reads every run's task: nhsim must be where it runs too
                try:
                    self._client.run_on_scheduler(importlib.import_module, name)
                except Exception as exc:
                    raise DependencyError(self._cannot_import(name, str(exc), "the scheduler")) from exc
            got = self._client.run(importlib.import_module, name, on_error="return")
            failed = {worker: exc for worker, exc in sorted(got.items()) if isinstance(exc, BaseException)}
            if failed:
                which = "the workers" if len(failed) == len(got) else f"{len(failed)} of the {len(got)} workers"
                if len(failed) < len(got):
                    which += f" ({', '.join(failed)})"
                raise DependencyError(self._cannot_import(name, str(next(iter(failed.values()))), which))

    def _cannot_import(self, module: str, why: str, which: str) -> str:
        """The one line that refuses workers (or ``which`` "the scheduler") that cannot import ``module`` (nhsim's)."""
        where = (
            "the scheduler's environment and start it there ('dask scheduler')"
            if which == "the scheduler"
            else f"each worker's environment and start its workers there ('dask worker {self.where}')"
        )
        fix = (
            f"install nhsim (this version, with its dependencies) in {where}, or run here with {_LOCAL}"
            if self._cluster is None
            else "reinstall nhsim in this environment"
        )
        return f"{which} at {self.where} cannot import nhsim's {module} ({why}): {fix}"

    @contextlib.contextmanager
    def _watching(self) -> Iterator[None]:
        """Within the block, on a cluster of the user's, a thread says a wait without any worker
        (:meth:`_watch_workers`); a local cluster restarts its own workers."""
        if self._cluster is not None:
            yield
            return
        stop = threading.Event()
        thread = threading.Thread(target=self._watch_workers, args=(stop,), name="nhsim-watch-workers", daemon=True)
        thread.start()
        try:
            yield
        finally:
            stop.set()
            thread.join(timeout=2 * WORKER_CHECK_S)

    def _watch_workers(self, stop: threading.Event) -> None:
        """Until ``stop``: look at the scheduler's workers every :data:`WORKER_CHECK_S` seconds; once it has had
        none for :data:`NO_WORKER_S` seconds, say so (once), and say when a worker connects after that.

        Runs wait for a worker as long as it takes, as a batch queue holds a job until its resources come: a
        deadline would end a study that would go on when a worker comes back (started after the command, or
        restarted after a crash), and Ctrl-C stops it at any moment, finished runs kept.
        """
        since: float | None = None  # when the scheduler was first seen without a worker
        said = False
        while not stop.wait(WORKER_CHECK_S):
            try:
                workers = len(self._client.nthreads())
            except Exception:  # the client closing, the scheduler gone: for the runs' own wait to report
                return
            if workers:
                if said:
                    self._notify(f"{workers} worker{'s' * (workers > 1)} connected to {self.where}: the runs go on")
                since, said = None, False
            elif since is None:
                since = time.monotonic()
            elif not said and time.monotonic() - since >= NO_WORKER_S:
                kept = f": {self._kept}" if self._kept else ""
                self._notify(
                    f"no worker is connected to {self.where}; the runs wait for one: start one with 'dask worker "
                    f"{self.where}' where nhsim is installed, or press Ctrl-C to stop{kept}"
                )
                said = True

    def close(self, abandon: bool = False) -> None:
        """Close the client, then, if it was started here, the local cluster.

        Args:
            abandon: Kill the local workers' processes as soon as the close reaches them, rather than
                let each finish its current run: Dask's close waits up to 4 s for a busy worker
                before it kills it, so an interrupted study took 3-5 s to stop. Dask's reports of
                what that breaks (connections closed under a heartbeat or a broadcast, tasks
                cancelled) are not shown: the command says it was interrupted.
        """
        from planning.signals import signals_held

        # A close of idle workers takes a fraction of a second; an interrupt that cut it short left Dask's
        # own finalisers to wait 10 s for it. So an interrupt during it is acted on once it is done.
        with _logging_off() if abandon else signals_held():
            if self._client is not None:
                self._client.close()
            if self._cluster is None:
                return
            killer = _killer(list(self._cluster.workers.values())) if abandon else None
            self._cluster.close()
            if killer is not None:
                killer.join()


@contextlib.contextmanager
def _logging_off() -> Iterator[None]:
    """No log record of this process is emitted within the block (``logging.disable``)."""
    previous = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(previous)


class _SyncCancelReport(logging.Filter):
    """Drops Tornado's report of the failure of Dask's ``sync`` cancel callback.

    Interrupted while it waits in ``distributed.utils.sync``, the calling thread schedules a callback that
    cancels the awaited future; when the interrupt came before that future was made, the callback fails
    with ``NameError: cannot access free variable 'future'`` on the event loop's thread, which Tornado
    logs as "Exception in callback", beside the command's "interrupted". Only an interrupt schedules
    that callback, so no report of a run's own error is dropped.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if not isinstance(exc, NameError) or exc.__traceback__ is None:
            return True
        tb = exc.__traceback__
        while tb.tb_next is not None:
            tb = tb.tb_next
        code = tb.tb_frame.f_code
        return not (code.co_name == "cancel" and code.co_filename.endswith(os.path.join("distributed", "utils.py")))


_CANCEL_REPORTS = _SyncCancelReport()


def _drop_cancel_reports() -> None:
    """Put :class:`_SyncCancelReport` on Tornado's application logger (once)."""
    logging.getLogger("tornado.application").addFilter(_CANCEL_REPORTS)


def _killer(nannies: list[Any], wait_s: float = 2.0) -> threading.Thread:
    """A started thread that SIGKILLs the worker process of each nanny once the nanny is closing, so
    it will not start the worker again, or leaves it after ``wait_s`` seconds."""
    from distributed.core import Status

    pending = [(n, n.pid) for n in nannies if n.pid]  # the pid read now: a closed nanny forgets its process

    def run() -> None:
        end = time.monotonic() + wait_s
        while pending and time.monotonic() < end:
            for n, pid in [(n, pid) for n, pid in pending if n.status in (Status.closing, Status.closed)]:
                pending.remove((n, pid))
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
            time.sleep(0.005)

    thread = threading.Thread(target=run, name="nhsim-kill-workers", daemon=True)
    thread.start()
    return thread


def _advice(address: str) -> str:
    return (
        f"is {address} a Dask scheduler's port (8786 by default; the dashboard's 8787 is a web page)? Start one with "
        f"'dask scheduler' and workers with 'dask worker ADDRESS', or run here with {_LOCAL}"
    )


def check_scheduler(address: str, timeout: float, notify: Callable[[str], None] | None = None) -> None:
    """Check that a Dask scheduler answers at ``address`` within ``timeout`` seconds, before Dask's
    client connects: the client's handshake waits without a deadline for a silent server and reads
    any other server's reply as the length of a Dask message (an HTTP reply asks for exabytes).

    A scheduler greets first: on accepting a connection it sends its handshake, an 8-byte length then
    the message. So the check connects (retrying a refused connection until the deadline, as Dask does
    for a scheduler still starting), reads those 8 bytes and the message, and sends nothing; a server
    silent until 1 s before the deadline is asked ``HEAD / HTTP/1.0`` so that a web server names
    itself. Addresses other than ``tcp://`` (TLS, websockets) are left to Dask's own timeout.

    Args:
        address: ``tcp://HOST:PORT`` or ``HOST:PORT`` (Dask's address forms).
        timeout: Seconds for all of it.
        notify: Told once when refused connections have been retried for a second (the wait goes on to the
            deadline, as a scheduler still starting refuses them): a wait past a second says so.

    Raises:
        ConfigError: Not an address, nothing reachable, or something other than a Dask scheduler
            answered (naming the address and what answered).
    """
    scheme, host, port = scheduler_address(address)
    if scheme != "tcp":
        return
    deadline = time.monotonic() + timeout
    sock = _connect(address, host, port, deadline, timeout, notify)
    with sock:
        answer = _greeting(sock, deadline, timeout)
    if answer is None:
        return
    raise ConfigError(f"no Dask scheduler at {address}: {answer}; {_advice(address)}")


def scheduler_address(address: str) -> tuple[str, str, int]:
    """``--scheduler``'s address as (scheme, host, port), read as Dask reads it (nothing is contacted).

    Raises:
        ConfigError: Not an address (naming it and the form to give).
    """
    from distributed.comm.addressing import get_address_host_port, parse_address

    try:
        scheme = parse_address(address)[0]
        host, port = get_address_host_port(address)
    except ValueError as exc:
        raise ConfigError(
            f"{option('scheduler', address)} is not a scheduler address ({exc}); give tcp://HOST:PORT, e.g. "
            "tcp://127.0.0.1:8786"
        ) from exc
    return scheme, host, port


def _connect(
    address: str, host: str, port: int, deadline: float, timeout: float, notify: Callable[[str], None] | None = None
) -> socket.socket:
    """A TCP connection to ``host:port``, retried until ``deadline`` while refused (``notify`` told once, after a
    second of it)."""
    said_at = time.monotonic() + 1.0
    while True:
        try:
            return socket.create_connection((host, port), timeout=max(0.01, deadline - time.monotonic()))
        except socket.gaierror as exc:
            raise ConfigError(f"cannot reach the Dask scheduler at {address}: unknown host {host!r} ({exc})") from exc
        except OSError as exc:
            if time.monotonic() + 0.1 >= deadline:
                raise ConfigError(
                    f"cannot reach the Dask scheduler at {address} within {timeout:g} s ({exc}); {_advice(address)}"
                ) from exc
            if notify is not None and time.monotonic() >= said_at:
                notify(f"waiting for the Dask scheduler at {address} ({exc.strerror or exc}), up to {timeout:g} s")
                notify = None
            time.sleep(0.1)


def _recv(sock: socket.socket, n: int, until: float) -> bytes:
    """Up to ``n`` bytes, fewer when the peer closes or ``until`` (monotonic) passes."""
    data = b""
    while len(data) < n and (left := until - time.monotonic()) > 0:
        sock.settimeout(left)
        try:
            chunk = sock.recv(n - len(data))
        except TimeoutError:
            break
        if not chunk:
            break
        data += chunk
    return data


def _first_line(data: bytes) -> str:
    return data.split(b"\r")[0].split(b"\n")[0].decode(errors="replace")


def _greeting(sock: socket.socket, deadline: float, timeout: float) -> str | None:
    """None when the peer greets as a Dask scheduler does, else what it did instead."""
    quiet_until = deadline - min(1.0, (deadline - time.monotonic()) / 2)
    head = _recv(sock, 8, quiet_until)
    if len(head) == 8:
        (size,) = struct.unpack("Q", head)  # Dask's frame header: native uint64, as distributed.comm.tcp reads it
        if size > MAX_GREETING_BYTES:
            answered = _first_line(head + _recv(sock, 64, min(deadline, time.monotonic() + 0.2)))
            return f"the server answered {answered!r}, not a Dask scheduler's greeting"
        if len(_recv(sock, size, deadline)) < size:
            return "the server began a greeting and did not finish it in time"
        return None
    if head:
        return f"the server sent {head!r} and stopped, not a Dask scheduler's greeting"
    try:
        sock.sendall(b"HEAD / HTTP/1.0\r\n\r\n")
    except OSError:
        return "the server closed the connection without a word"
    reply = _recv(sock, 64, deadline)
    if reply.startswith(b"HTTP/"):
        return f"an HTTP server answered ({_first_line(reply)}), not a Dask scheduler"
    if reply:
        return f"the server answered {reply!r}, not a Dask scheduler's greeting"
    return f"the server accepted the connection but sent nothing within {timeout:g} s"


def max_jobs() -> int:
    """The most local worker processes ``--jobs`` may ask for: :data:`JOBS_PER_CORE` per core this
    process may use (each run keeps a core busy; more processes only share the cores and the memory)."""
    return JOBS_PER_CORE * default_jobs()


def check_workers(n: int, flag: str = "jobs", *, elsewhere: str = "") -> int:
    """``n`` local worker processes, asked for by ``flag``, checked: at least 1, at most :func:`max_jobs`.

    Args:
        n: Worker processes.
        flag: The option that asked for them (without its dashes; also the Python keyword), named in the
            message (:func:`planning.errors.option`).
        elsewhere: Advice appended to the message about too many (e.g. run on a cluster).

    Raises:
        ConfigError: ``n`` < 1 or above :func:`max_jobs`, naming ``flag`` and the bound.
    """
    n = check_number(option(flag), n, integer=True, at_least=1)
    if n > max_jobs():
        cores = default_jobs()
        raise ConfigError(
            f"{option(flag, n)} would start {n} worker processes on the {cores} core{'s' if cores != 1 else ''} this "
            f"process may use; give at most {max_jobs()} ({JOBS_PER_CORE} per core){elsewhere}"
        )
    return n


def worker_count(jobs: int | None = None, scheduler: str | None = None, *, default: int | None = None) -> int | None:
    """Check ``--jobs`` / ``--scheduler`` without starting anything: the local worker processes they ask
    for, or None for a cluster (its address read, not contacted: :func:`check_scheduler` does that).

    Args:
        jobs: Worker processes here, as given (None: not given); 1 runs in this process.
        scheduler: Address of a running Dask scheduler; exclusive with ``jobs``.
        default: Worker processes when neither is given (None: :func:`default_jobs`); a
            command's default, so that it never counts as a given ``--jobs``.

    Raises:
        ConfigError: Both given, ``jobs`` outside :func:`check_workers`' bounds (a cluster decides its own
            workers), or a scheduler address that is no address.
    """
    if scheduler is not None and jobs is not None:
        raise ConfigError(
            f"{options('jobs', 'scheduler')} exclude each other: run here with J processes, or on a cluster"
        )
    if scheduler is not None:
        scheduler_address(scheduler)
        return None
    n = jobs if jobs is not None else default if default is not None else default_jobs()
    cluster = option("scheduler", "ADDRESS", python="scheduler=ADDRESS")
    return check_workers(n, elsewhere=f", or run on a Dask cluster with {cluster}")


def make_executor(
    jobs: int | None = None,
    scheduler: str | None = None,
    *,
    default: int | None = None,
    notify: Callable[[str], None] | None = None,
    kept: str = "",
) -> Executor:
    """The executor for ``--jobs`` / ``--scheduler`` (see the module docstring), checked by :func:`worker_count`;
    ``notify`` and ``kept`` as :class:`DaskExecutor` takes them.

    Raises:
        ConfigError: As :func:`worker_count`, or an unreachable scheduler.
    """
    n = worker_count(jobs, scheduler, default=default)
    if n is None:
        assert scheduler is not None
        return DaskExecutor(address=scheduler, notify=notify, kept=kept)
    return Executor() if n == 1 else DaskExecutor(jobs=n, notify=notify, kept=kept)
