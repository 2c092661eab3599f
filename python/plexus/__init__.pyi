"""Type stubs for plexus (the compiled _plexus and the Python modules around it)."""

import builtins
from typing import Any, Callable, Iterator, Literal, Optional, Union, overload

import numpy

Data = Union[None, bool, int, float, str, bytes, "numpy.ndarray[Any, Any]", list["Data"], dict[str, "Data"]]
Writable = Union[Data, tuple["Writable", ...], bytearray, memoryview, "numpy.generic"]

class Error(Exception):
    """Anything that went wrong in Plexus; ``code`` is the C++ ErrorCode (the CLI's exit status)."""

    code: int
    message: str
    def __init__(self, message: str = ...) -> None: ...

class NotFoundError(Error, LookupError):
    """The daemon answered "no" (code 1)."""

class UsageError(Error, ValueError):
    """A wrong request: bad port name, policy, a closed port... (code 2)."""

class TimeoutError(Error, builtins.TimeoutError):
    """No answer in time (code 3)."""

class RefusedError(Error, ConnectionError):
    """Refused: no daemon, a refused connect, a broken link (code 4)."""

class Envelope:
    """Where a message comes from."""

    @property
    def source(self) -> str:
        """The port that wrote the message."""
    @property
    def seq(self) -> int:
        """The source's sequence number, from 1."""
    @property
    def time_ns(self) -> int:
        """Send time, ns since the Unix epoch."""
    @property
    def time(self) -> float:
        """Send time, seconds since the Unix epoch."""

class Message:
    """A received message."""

    @property
    def data(self) -> Data:
        """The payload (blobs as bytes, .npy blobs as numpy.ndarray viewing the received memory)."""
    @property
    def envelope(self) -> Envelope:
        """Source, sequence number and send time."""

class Loan:
    """A buffer for one blob message: memoryview(loan) / numpy.frombuffer(loan, dtype), then
    Port.send_loan(loan)."""

    @property
    def in_shared_memory(self) -> bool: ...
    def __len__(self) -> int: ...
    def __buffer__(self, flags: int) -> memoryview: ...

class MessageView:
    """A message read in place (Port.read_view): memoryview(view) is its blob, read-only."""

    @property
    def envelope(self) -> Envelope: ...
    @property
    def in_place(self) -> bool: ...
    def value(self) -> Any: ...
    def release(self) -> None: ...
    def __buffer__(self, flags: int) -> memoryview: ...
    def __enter__(self) -> MessageView: ...
    def __exit__(self, *args: object) -> None: ...

class Port:
    """A port opened by Client.open. Closing it flushes what was written."""

    @property
    def name(self) -> str:
        """The port's name."""
    @property
    def is_open(self) -> bool:
        """False once closed."""
    @property
    def dropped_while_disconnected(self) -> int:
        """Messages written while the daemon was away and dropped beyond the bound."""
    def write(self, data: Writable, flush: bool = True) -> None:
        """Writes a message to every connection out of this port."""
    def flush(self) -> None:
        """Sends what write(..., flush=False) buffered."""
    def read(self, timeout: Optional[float] = None) -> Optional[Message]:
        """The next message, waiting up to `timeout` s (None: for ever); None if none came."""
    def loan(self, size: int) -> Loan:
        """A Loan of `size` bytes for one blob message, in this port's shared memory when it can be."""
    def send_loan(self, loan: Loan, flush: bool = True) -> None:
        """Sends a filled Loan as one blob message (the loan cannot be used after)."""
    def read_view(self, timeout: Optional[float] = None) -> Optional[MessageView]:
        """Like read, but a blob written in shared memory on this machine is read in place."""
    async def read_async(self, timeout: Optional[float] = None) -> Optional[Message]:
        """read() for asyncio: waits without blocking the event loop."""
    def close(self) -> None:
        """Flushes and closes the port."""
    def __iter__(self) -> Iterator[Message]: ...
    def __next__(self) -> Message: ...
    def __aiter__(self) -> Port: ...
    async def __anext__(self) -> Message: ...
    def __enter__(self) -> Port: ...
    def __exit__(self, *args: object) -> None: ...

class Client:
    """A connection to the local daemon."""

    def __init__(self, socket: Optional[str] = None, request_timeout: float = 10.0) -> None:
        """Connects to the daemon at `socket` (None: $PLEXUS_SOCKET, else the per-user path)."""
    @property
    def socket_path(self) -> str:
        """The socket path this client is connected to."""
    def open(self, name: str, policy: Literal["strict", "latest"] = "strict", capacity: int = 0) -> Port:
        """Opens a port on the local daemon and registers it."""
    def connect(self, source: str, destination: str, carrier: str = "", persist: bool = False) -> str:
        """Connects two ports; returns the carrier used."""
    def disconnect(self, source: str, destination: str) -> None:
        """Removes the connection source -> destination."""
    def exists(self, port: str, destination: Optional[str] = None) -> bool:
        """Whether the port (or the connection port -> destination, up) exists."""
    def lookup(self, port: str) -> Optional[dict[str, Any]]:
        """Where a port lives, or None."""
    def list(self) -> dict[str, Any]:
        """Ports and connections as the name server knows them."""
    def stats(self, port: str = "") -> dict[str, Any]:
        """Counters of the local daemon or of the daemon hosting `port`."""
    def events(self, port: str, check: bool = False) -> dict[str, Any]:
        """The arbitration of an input port."""
    def ping(self, port: str) -> dict[str, Any]:
        """Node and address of the daemon hosting `port`."""
    @overload
    def request(self, body: dict[str, Any]) -> Any:
        """Any control request; the reply body."""
    @overload
    def request(self, port: str, value: Any, timeout: float = 10.0) -> Any:
        """Calls the service at `port`; the answer's value (docs/CALLS.md)."""
    async def request_async(self, port: str, value: Any, timeout: float = 10.0) -> Any:
        """The same without blocking the event loop."""
    def serve(self, port: str, handler: Callable[[Any], Any]) -> Service:
        """Opens `port` to serve it: each call is answered with handler(value)."""

class Service:
    """Answers the calls of one served port until closed."""

    @property
    def port(self) -> str: ...
    @property
    def calls(self) -> int: ...
    def close(self) -> None: ...
    def __enter__(self) -> Service: ...
    def __exit__(self, *args: object) -> None: ...
