"""Plexus for Python: ports, messages and connections through the local plexusd.

    import plexus
    client = plexus.Client()                      # the local daemon ($PLEXUS_SOCKET)
    out = client.open("/camera/out")
    inp = client.open("/viewer/in", policy="latest", capacity=4)
    client.connect("/camera/out", "/viewer/in")
    out.write({"frame": 1, "pixels": numpy.zeros((480, 640, 3), numpy.uint8)})
    message = inp.read(timeout=1.0)               # a Message, or None after 1 s
    message.data["pixels"].shape, message.envelope.source, message.envelope.seq

Blocking reads release the GIL and Ctrl-C interrupts them; ``await port.read_async()`` and
``async for message in port`` serve asyncio. Errors raise plexus.Error (NotFoundError,
UsageError, TimeoutError, RefusedError) with the messages the CLI prints. NumPy arrays travel as
blobs holding a .npy file (see python/README.md). ``plexus.Recording(path)`` reads a recording
made by ``plexus record`` (docs/RECORDING.md).
"""

from . import _asyncio
from ._errors import Error, NotFoundError, RefusedError, TimeoutError, UsageError
from ._plexus import (Client, Envelope, Loan, Message, MessageView, Port, RecordedMessage, Recording,
                      Service)

_asyncio.install()

__all__ = [
    "Client",
    "Envelope",
    "Error",
    "Loan",
    "Message",
    "MessageView",
    "NotFoundError",
    "Port",
    "RecordedMessage",
    "Recording",
    "Service",
    "RefusedError",
    "TimeoutError",
    "UsageError",
]
