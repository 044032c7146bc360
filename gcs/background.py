"""Work beside the planner: a forked helper process that imports its slow modules (matplotlib,
rerun) while the parent plans, then does what the parent sends it, in order.

    with Background(warm_up) as helper:              # forks now; warm_up() runs in the helper
        recorder = helper.create(PlanRecorder, ...)  # an object living in the helper
        recorder.call("log_step", record)            # arguments pickled now, the call made there
        job = helper.submit(draw, plan, path)        # a function run there, for its result
        saved = recorder.submit("close")             # a method of an object there, for its result
        values = helper.results()                    # values[job]; a failure is raised here

Calls and jobs are sent without waiting for the helper, which reads them as they come (also
while it warms up), so the parent never stalls on it. Ctrl-C is the parent's to handle (the
helper ignores it and finishes what it was sent); if the parent dies, the helper closes its
objects (`close()`) and exits. Where the process cannot fork safely (other threads running, or
not Linux: macOS frameworks do not survive a fork) everything runs in the caller, at once: same
results, no overlap."""

from __future__ import annotations

import gc
import multiprocessing
import pickle
import queue
import signal
import sys
import threading
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

_Outcome = tuple[bool, Any]  # (True, value) or (False, the exception raised)


def _picklable(exc: BaseException) -> BaseException:
    try:
        pickle.dumps(exc)
        return exc
    except Exception:
        return RuntimeError(f"{type(exc).__name__}: {exc}")


class _Runner:
    """Jobs, objects and calls, run where they land (the helper, or the caller when inline)."""

    def __init__(self) -> None:
        self.objects: dict[int, Any] = {}
        self.outcomes: list[_Outcome] = []
        self.failure: BaseException | None = None  # the first failed create or call

    def run(self, message: tuple) -> None:
        kind, *rest = message
        if kind in ("job", "method"):
            try:
                if kind == "job":
                    fn, args = rest
                else:  # a method of an object: after a failed creation or call, that failure
                    key, name, args = rest
                    if self.failure is not None:
                        raise self.failure
                    fn = getattr(self.objects[key], name)
                self.outcomes.append((True, fn(*args)))
            except Exception as exc:
                self.outcomes.append((False, exc))
            return
        try:
            if kind == "new":
                key, factory, args, kwargs = rest
                self.objects[key] = factory(*args, **kwargs)
            elif rest[0] in self.objects:  # a call on an object whose creation failed is dropped
                key, name, args, kwargs = rest
                getattr(self.objects[key], name)(*args, **kwargs)
        except Exception as exc:
            if self.failure is None:
                self.failure = exc

    def close_objects(self) -> None:
        for obj in self.objects.values():
            close = getattr(obj, "close", None)
            if callable(close):
                close()


def _serve(conn: Connection, parent_end: Connection, warm_up: Callable[[], None] | None) -> None:
    parent_end.close()  # the parent's end, inherited: closed here, so that the parent closing it ends the input
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    inbox: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()

    def receive() -> None:
        try:
            while True:
                inbox.put(conn.recv_bytes())
        except (EOFError, OSError):
            inbox.put(None)

    threading.Thread(target=receive, daemon=True).start()
    runner = _Runner()
    gc.disable()  # while the slow modules load: imports allocate much and free little
    if warm_up is not None:
        try:
            warm_up()
        except Exception as exc:
            runner.failure = exc
    gc.freeze()  # what was inherited and what the warm-up loaded: never collected, so never copied
    gc.enable()
    while (data := inbox.get()) is not None:
        message = pickle.loads(data)
        if message[0] == "end":
            outcomes = [(ok, value if ok else _picklable(value)) for ok, value in runner.outcomes]
            failure = _picklable(runner.failure) if runner.failure is not None else None
            conn.send((outcomes, failure))
            return
        runner.run(message)
    runner.close_objects()  # the parent is gone


class Remote:
    """An object living in the helper; `call` runs one of its methods there."""

    def __init__(self, helper: Background, key: int) -> None:
        self._helper = helper
        self._key = key

    def call(self, name: str, *args: Any, **kwargs: Any) -> None:
        self._helper._send(("call", self._key, name, args, kwargs))

    def submit(self, name: str, *args: Any) -> int:
        """Run its method `name(*args)` there, as a job: its value is `results()[index]`, the
        index returned."""
        return self._helper._job(("method", self._key, name, args))


class Background:
    """One helper process for one command; see the module docstring."""

    def __init__(self, warm_up: Callable[[], None] | None = None) -> None:
        self._runner = _Runner()  # inline: the work is done here
        self._jobs = 0
        self._objects = 0
        self._conn: Connection | None = None
        self._sent = False
        if sys.platform == "linux" and threading.active_count() == 1:
            context = multiprocessing.get_context("fork")
            self._conn, child = context.Pipe()
            self._process = context.Process(target=_serve, args=(child, self._conn, warm_up), daemon=True,
                                            name="gcs-background")
            gc.freeze()  # the helper's collections skip, and so never copy, what it inherits
            self._process.start()
            gc.unfreeze()
            child.close()

    def _send(self, message: tuple) -> None:
        if self._conn is None:
            self._runner.run(message)
        else:
            self._conn.send_bytes(pickle.dumps(message))
            self._sent = True

    def submit(self, fn: Callable[..., Any], *args: Any) -> int:
        """Run `fn(*args)` in the helper; its value is `results()[index]`, the index returned."""
        return self._job(("job", fn, args))

    def _job(self, message: tuple) -> int:
        self._send(message)
        self._jobs += 1
        return self._jobs - 1

    def create(self, factory: Callable[..., Any], *args: Any, **kwargs: Any) -> Remote:
        """`factory(*args, **kwargs)` made in the helper, to call methods of."""
        self._objects += 1
        self._send(("new", self._objects, factory, args, kwargs))
        return Remote(self, self._objects)

    def results(self) -> list[Any]:
        """Wait until the helper has done everything sent; the jobs' values in order. Raises the
        first failure of a job, object or call. Stops the helper."""
        outcomes, failure = self._runner.outcomes, self._runner.failure
        if self._conn is not None:
            self._send(("end",))
            try:
                outcomes, failure = self._conn.recv()
            except EOFError:
                self.close()
                raise RuntimeError(f"the background process died (exit code {self._process.exitcode})") from None
            self.close()
        for ok, value in outcomes:
            if not ok:
                raise value
        if failure is not None:
            raise failure
        return [value for _, value in outcomes]

    def close(self) -> None:
        """Stop the helper once it has done what it was sent (results not collected are
        dropped; sent nothing, it is stopped at once) and wait for it; inline, close the
        objects made."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None
            if not self._sent:
                self._process.terminate()
            self._process.join()
        else:
            self._runner.close_objects()
            self._runner.objects.clear()

    def __enter__(self) -> Background:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
