#!/usr/bin/env python3
"""A minimal Plexus component in Python: the same as examples/cpp/counter.cpp.

Opens /counter/out and /counter/in, connects them, writes a few counted messages and reads them
back. Needs a running plexusd (PLEXUS_SOCKET says where, if not the default). Exits 0 when every
message came back in order: `python3 counter.py [COUNT]`.
"""
import sys

import plexus


def main():
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    client = plexus.Client()
    out = client.open("/counter/out")
    inp = client.open("/counter/in", policy="strict", capacity=16)
    client.connect("/counter/out", "/counter/in")

    for n in range(1, count + 1):
        out.write({"n": n, "text": f"message {n}"})

    for n in range(1, count + 1):
        message = inp.read(timeout=5.0)
        if message is None or message.data["n"] != n:
            sys.exit(f"counter.py: expected message {n}, got {message.data if message else 'nothing within 5 s'}")
        print("received", message.data, "from", message.envelope.source)


if __name__ == "__main__":
    main()
