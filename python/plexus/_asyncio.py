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

from ._plexus import Message, Port

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


def install() -> None:
    """Adds the asyncio methods to Port (they are Python; the rest of Port is compiled)."""
    Port.read_async = read_async
    Port.__aiter__ = _aiter
    Port.__anext__ = _anext
