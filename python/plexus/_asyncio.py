"""asyncio for ports: ``await port.read_async()`` and ``async for message in port``.

libplexus has no descriptor to wait on, so a read runs in a thread of the port's own (a
one-thread executor: one reader per port, as libplexus wants, and ports do not compete for the
loop's default executor). The thread reads in short slices: a cancelled read_async leaves at most
one slice running, and what that slice receives is kept for the next read_async, never lost.
A message costs a hand-over from that thread to the loop (tens of microseconds).
"""

from __future__ import annotations

import asyncio
import concurrent.futures

from ._plexus import Client, Message, Port

_SLICE = 0.1  # seconds a reader thread waits before looking again whether anyone still waits


def _executor(port: Port) -> concurrent.futures.ThreadPoolExecutor:
    executor = port.__dict__.get("_reader")
    if executor is None:
        executor = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="plexus-read " + port.name)
        port._reader = executor
    return executor


async def read_async(self: Port, timeout: float | None = None) -> Message | None:
    """Waits up to `timeout` seconds (None: for ever) for the next message without blocking the
    event loop; returns a Message, or None if none came. One reader per port at a time."""
    loop = asyncio.get_running_loop()
    deadline = None if timeout is None else loop.time() + timeout
    while True:
        pending = self.__dict__.get("_pending")
        if pending is None or pending.get_loop() is not loop:
            left = _SLICE if deadline is None else max(0.0, min(_SLICE, deadline - loop.time()))
            pending = loop.run_in_executor(_executor(self), self.read, left)
            self._pending = pending
        # shield: a cancelled caller leaves the slice running; its message waits in _pending.
        message = await asyncio.shield(pending)
        self._pending = None
        if message is not None:
            return message
        if deadline is not None and loop.time() >= deadline:
            return None


def _aiter(self: Port) -> Port:
    return self


async def _anext(self: Port) -> Message:
    """The next message, waiting for ever; the iteration ends when the port is closed."""
    try:
        return await read_async(self)
    except Exception:
        if not self.is_open:
            raise StopAsyncIteration from None
        raise


async def request_async(self: Client, port: str, value, timeout: float = 10.0):
    """Calls the service at `port` without blocking the event loop; the answer's value, or the
    exception request() would raise. No thread per call: the client's receiving thread completes
    the future through the loop (many calls may be outstanding at once)."""
    loop = asyncio.get_running_loop()
    future = loop.create_future()

    def settle(result, error) -> None:
        if future.done():  # cancelled meanwhile: the answer has nobody to go to
            return
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(result)

    def done(result, error) -> None:  # on a thread of the client, with the GIL
        loop.call_soon_threadsafe(settle, result, error)

    self._request_then(port, value, timeout, done)
    return await future


def install() -> None:
    """Adds the asyncio methods to Port and Client (they are Python; the rest is compiled)."""
    Client.request_async = request_async
    Port.read_async = read_async
    Port.__aiter__ = _aiter
    Port.__anext__ = _anext
