"""A local process pool whose workers can be stopped at once, and the signal handling
that lets one Ctrl-C (or SIGTERM) stop a long study within a second, leaving no child.

Each worker has its own pipe (a worker killed half-way through sending reads as
end-of-file), ignores SIGINT (only the parent decides to stop), dies on SIGTERM and dies
with its parent (even one killed with SIGKILL, which can clean nothing up); the thread
handing out tasks is a daemon the interpreter does not wait for at exit.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import multiprocessing.connection
import os
import select
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager, suppress
from multiprocessing.connection import Connection

INTERRUPTS = (signal.SIGINT, signal.SIGTERM)
"""The signals that stop a study."""
KILL_WAIT_S = 1.0
"""How long terminated workers get to exit before they are killed, s."""
PARENT_POLL_S = 0.25
"""How often a worker without a parent-death signal checks that its parent lives, s."""
PR_SET_PDEATHSIG = 1
"""Linux prctl option: the signal this process gets when the thread that forked it ends."""


@contextmanager
def interrupts_ignored() -> Iterator[None]:
    """Ignore SIGINT and SIGTERM inside the block (a no-op outside the main thread).

    Cleanup after an interrupt runs in here, so that a second Ctrl-C cannot break it
    off half-way; the previous handlers are restored at the end.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {sig: signal.signal(sig, signal.SIG_IGN) for sig in INTERRUPTS}
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)


@contextmanager
def interrupts_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back in this thread inside the block (delivered after it).

    Processes and threads started in here inherit the blocked mask: pool workers then
    never see a signal before their initializer ignores it, and helper threads never
    take a signal meant for the main thread.
    """
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, INTERRUPTS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def rearm_handlers() -> None:
    """Install this process's Python SIGINT and SIGTERM handlers again (main thread).

    Gmsh, when it initialises for a mesh build, puts SIGTERM back to its default action
    under a Python handler (the Python-level view does not change): a serial sweep
    re-arms its handlers after each point, so that SIGTERM still stops it cleanly.
    """
    if threading.current_thread() is not threading.main_thread():
        return
    for sig in INTERRUPTS:
        handler = signal.getsignal(sig)
        if handler is not None:
            signal.signal(sig, handler)


def _set_parent_death_signal() -> bool:
    """Ask Linux to SIGKILL this process when its parent ends; False where it cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent: int) -> None:
    """Watchdog loop: end this process as soon as its parent is no longer `parent`."""
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    os._exit(1)


def _start_watchdog(parent: int) -> None:
    """Run `_watch_parent` in a daemon thread (a worker busy in a solve reads no pipe)."""
    threading.Thread(target=_watch_parent, args=(parent,), name="fecheck-parent-watch",
                     daemon=True).start()


def _watch_process(pid: int) -> None:
    """Watchdog body: end this process as soon as process `pid` ends (a pidfd becomes
    readable then, a zombie included; without one, poll every `PARENT_POLL_S`)."""
    try:
        fd = os.pidfd_open(pid)
    except (AttributeError, OSError):
        fd = None
    if fd is not None:
        select.select([fd], [], [])
    else:
        while _exists(pid):
            time.sleep(PARENT_POLL_S)
    os._exit(1)


def _exists(pid: int) -> bool:
    """Whether process `pid` exists."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def die_with(pid: int) -> None:
    """Make this process end when process `pid` ends, even by SIGKILL, whether `pid` is
    its parent or further up (a stress case, forked by a fork server, dies with the run
    that started the server): a daemon thread waits for it."""
    threading.Thread(target=_watch_process, args=(pid,), name="fecheck-run-watch",
                     daemon=True).start()


def die_with_parent(parent: int) -> None:
    """Make this process end when its parent, pid `parent`, does (even by SIGKILL).

    On Linux the kernel sends it SIGKILL when the parent ends (the parent-death signal,
    strictly: when the parent's thread that started it ends; a pool lives no longer than
    the call that made it); elsewhere a daemon thread checks the parent's pid every
    `PARENT_POLL_S`. If the parent ended before the signal was set, this process already
    has another parent: it exits at once.
    """
    if not _set_parent_death_signal():
        _start_watchdog(parent)
    if os.getppid() != parent:
        os._exit(1)


def _init_worker(parent: int) -> None:
    """Pool worker start: die with `parent`, ignore SIGINT (the parent decides), die on
    SIGTERM."""
    die_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, INTERRUPTS)


def _worker_main(conn: Connection, parent: int, inherited: list[Connection]) -> None:
    """A pool worker: run ``(fn, args)`` tasks from `conn`, send back ``(ok, value)``.

    Stops at ``None``, when the parent's end of `conn` is gone, or when the parent `parent`
    ends. `inherited`: the parent's pipe ends a forked worker holds copies of, closed at
    the start (while the worker holds the parent's end of `conn`, that end is never gone).
    """
    _init_worker(parent)
    for other in inherited:
        other.close()
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        fn, args = task
        try:
            reply = (True, fn(*args))
        except Exception as err:
            reply = (False, err)
        try:
            conn.send(reply)
        except Exception as err:
            conn.send((False, RuntimeError(f"cannot send the result back: "
                                           f"{type(err).__name__}: {err}")))


class ProcessPool(Executor):
    """A local process pool whose workers can be terminated at once.

    Each worker has its own pipe, so a worker killed half-way through sending its result
    reads as end-of-file (a shared queue would be left half-written and block its reader
    for good), and the thread handing out tasks is a daemon the interpreter does not wait
    for at exit. Workers ignore SIGINT: only the parent decides to stop; they die with
    the parent (`die_with_parent`), so that a parent killed with SIGKILL leaves none.
    """

    def __init__(self, workers: int):
        self._lock = threading.Lock()
        self._queued: deque[tuple[Future, Callable, tuple]] = deque()
        self._closing = False
        self._wake_r, self._wake_w = multiprocessing.Pipe(duplex=False)
        self._workers: dict[Connection, multiprocessing.Process] = {}
        forked = multiprocessing.get_start_method() == "fork"
        with interrupts_held():
            for i in range(workers):
                mine, theirs = multiprocessing.Pipe()
                inherited = ([self._wake_r, self._wake_w, *self._workers, mine] if forked
                             else [])
                process = multiprocessing.Process(
                    target=_worker_main, args=(theirs, os.getpid(), inherited),
                    name=f"fecheck-sweep-{i}", daemon=True)
                process.start()
                theirs.close()
                self._workers[mine] = process
            self._thread = threading.Thread(target=self._serve, name="fecheck-sweep-pool",
                                            daemon=True)
            self._thread.start()

    def submit(self, fn, /, *args, **kwargs) -> Future:
        """Queue ``fn(*args)`` (no keyword arguments) for a worker."""
        if kwargs:
            raise TypeError("the sweep pool takes positional arguments only")
        future: Future = Future()
        with self._lock:
            if self._closing:
                raise RuntimeError("cannot submit to a pool that was shut down")
            self._queued.append((future, fn, args))
        self._wake()
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop taking tasks; `cancel_futures` drops the queued ones; `wait` waits for the
        running ones and the workers' exit (workers still alive after 1 s are killed)."""
        with self._lock:
            self._closing = True
            if cancel_futures:
                for future, _, _ in self._queued:
                    future.cancel()
                self._queued.clear()
        self._wake()
        if wait:
            self._thread.join()
            self._stop_processes(terminate=False)

    def terminate(self) -> None:
        """Cancel the queued tasks and terminate the workers now (killed after 1 s)."""
        self.shutdown(wait=False, cancel_futures=True)
        self._stop_processes(terminate=True)

    def _stop_processes(self, terminate: bool) -> None:
        """Wait up to 1 s for the workers to exit (after SIGTERM if `terminate`), kill the
        ones still alive, and reap them all."""
        processes = list(self._workers.values())
        if terminate:
            for process in processes:
                process.terminate()
        pending = [p.sentinel for p in processes]
        deadline = time.monotonic() + KILL_WAIT_S
        while pending and time.monotonic() < deadline:
            ready = multiprocessing.connection.wait(pending, deadline - time.monotonic())
            pending = [s for s in pending if s not in ready]
        for process in processes:
            if process.sentinel in pending:
                process.kill()
            process.join(KILL_WAIT_S)

    def _wake(self) -> None:
        """Wake the pool's thread (new task, or shutdown)."""
        with suppress(OSError):
            self._wake_w.send_bytes(b"")

    def _serve(self) -> None:
        """The pool's thread: hand queued tasks to idle workers, settle their futures."""
        idle = list(self._workers)
        running: dict[Connection, Future] = {}
        try:
            while True:
                self._hand_out(idle, running)
                with self._lock:
                    done = self._closing and not self._queued
                if not running and (done or not idle):
                    return
                for conn in multiprocessing.connection.wait([*running, self._wake_r]):
                    if conn is self._wake_r:
                        while self._wake_r.poll():
                            self._wake_r.recv_bytes()
                    else:
                        self._settle(conn, running.pop(conn), idle)
        finally:
            self._fail_queued()
            for conn in idle:
                with suppress(OSError):
                    conn.send(None)
            for conn in self._workers:
                conn.close()

    def _hand_out(self, idle: list[Connection], running: dict[Connection, Future]) -> None:
        """Send queued tasks to idle workers (cancelled ones are dropped)."""
        while idle:
            with self._lock:
                if not self._queued:
                    return
                future, fn, args = self._queued.popleft()
            if not future.set_running_or_notify_cancel():
                continue
            conn = idle.pop()
            try:
                conn.send((fn, args))
            except OSError as err:
                future.set_exception(BrokenProcessPool(f"a sweep worker is gone: {err}"))
                continue
            running[conn] = future

    def _settle(self, conn: Connection, future: Future, idle: list[Connection]) -> None:
        """Read a worker's reply into its future; a dead worker fails the future."""
        try:
            ok, value = conn.recv()
        except (EOFError, OSError):
            pid = self._workers[conn].pid
            future.set_exception(BrokenProcessPool(f"sweep worker pid {pid} died"))
            return
        if ok:
            future.set_result(value)
        else:
            future.set_exception(value)
        idle.append(conn)

    def _fail_queued(self) -> None:
        """Close the pool and fail the tasks still queued (no worker will run them)."""
        with self._lock:
            queued, self._closing = list(self._queued), True
            self._queued.clear()
        for future, _, _ in queued:
            if future.set_running_or_notify_cancel():
                future.set_exception(BrokenProcessPool("the sweep pool stopped"))


_CAUGHT: list[int] = []
"""The interrupts caught inside `interrupts_raised` (signal numbers, in order)."""


def _raise_interrupt(signum, frame) -> None:
    """SIGINT and SIGTERM handler: remember the signal, stop the way Ctrl-C does."""
    _CAUGHT.append(signum)
    raise KeyboardInterrupt


@contextmanager
def interrupts_raised() -> Iterator[None]:
    """Turn SIGINT and SIGTERM into KeyboardInterrupt in the block (main thread only).

    The signals are also remembered: a KeyboardInterrupt raised while a compiled kernel
    calls back into Python is swallowed there (numba does), and `raise_pending_interrupt`
    raises it again at the next safe point.
    """
    try:
        previous = {sig: signal.signal(sig, _raise_interrupt) for sig in INTERRUPTS}
    except ValueError:                       # not the main thread: leave signals alone
        yield
        return
    _CAUGHT.clear()
    try:
        yield
    finally:
        _CAUGHT.clear()                      # they belonged to the block
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)


def raise_pending_interrupt() -> None:
    """Raise KeyboardInterrupt if an interrupt was caught by `interrupts_raised` but
    swallowed before it could stop the work."""
    if _CAUGHT:
        raise KeyboardInterrupt
