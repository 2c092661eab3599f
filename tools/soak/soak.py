#!/usr/bin/env python3
"""Soak: Plexus under constant traffic while a chaos loop breaks things, then a count.

Three daemons (a, b, c) and a name server on loopback; traffic all along through tcp links with
a recv monitor (certainty), an input port arbitrated by stimulation between two sources, a local
connection and large (256 KiB) payloads. Meanwhile, every 0.5-2 s, one of: kill -9 a daemon and
start it again; kill -9 the name server and start it again; kill -9 a writer or a reader and start
a new one; garbage bytes (TCP and UDP) to every listener; a flood of 200 connects. At the end the
chaos stops, traffic runs on for a while, writers finish, readers drain, and the soak checks:
no process ended by itself, every counter balance holds (tools/soak/accounting.py), the clients
that outlived every restart of their daemon saw exactly what the daemon counted, and no daemon's
resident memory went beyond the bound.

    scripts/soak 600            # ten minutes; prints the figures; exit 0 only if all held
"""
import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import accounting  # noqa: E402
import chaos  # noqa: E402
from processes import Managed, Reader, Writer  # noqa: E402

ROOT = os.path.realpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", ".."))


def small_payload(rng):
    return lambda n: json.dumps({"n": n, "certainty": round(rng.random(), 3)})


def large_payload(n):
    return json.dumps({"n": n, "blob": "x" * (256 * 1024)})


class Soak:
    def __init__(self, args):
        self.args = args
        self.rng = random.Random(args.seed)
        self.work = tempfile.mkdtemp(prefix="plexus-soak-")
        self.build = args.build
        self.plexus = os.path.join(self.build, "tools", "plexus")
        self.crashes = []
        self.figures = {"daemon_kills": 0, "names_kills": 0, "client_kills": 0, "garbage_connections": 0,
                        "garbage_bytes": 0, "flood_connects": 0}
        self.names = None
        self.daemons = {}
        self.writers = []
        self.readers = []
        self.rss_samples = {}

    # --- start-up ------------------------------------------------------------------------------
    def start_names(self):
        ready = os.path.join(self.work, "names.ready")
        argv = [os.path.join(self.build, "daemon", "plexus-names"), "--listen", "127.0.0.1:0", "--ready-file", ready,
                "--state", os.path.join(self.work, "names.state"), "--log-level", "warn"]
        self.names = Managed("names", argv, ready, self.work, self.crashes)
        self.names.start()
        self.names.pin("--listen", self.names.info["names"])

    def start_daemon(self, node):
        ready = os.path.join(self.work, node + ".ready")
        argv = [os.path.join(self.build, "daemon", "plexusd"), "--node", node, "--socket",
                os.path.join(self.work, node + ".sock"), "--listen", "127.0.0.1:0", "--names",
                self.names.info["names"], "--scripts", os.path.join(ROOT, "configs", "monitors"), "--ready-file",
                ready, "--log-level", "warn"]
        daemon = Managed(node, argv, ready, self.work, self.crashes)
        daemon.start()
        daemon.pin("--listen", daemon.info["address"])
        self.daemons[node] = daemon

    def env(self, node):
        return dict(os.environ, PLEXUS_SOCKET=os.path.join(self.work, node + ".sock"),
                    PLEXUS_NAMES=self.names.info["names"])

    def cli(self, node, *args, timeout=30):
        return subprocess.run([self.plexus, *args], env=self.env(node), capture_output=True, text=True,
                              timeout=timeout)

    def wait_port(self, node, port):
        result = self.cli(node, "wait", port, "--timeout", "20")
        if result.returncode != 0:
            raise RuntimeError("port %s never appeared: %s" % (port, result.stderr))

    def start_traffic(self):
        rate = self.args.rate
        plan = [  # (writer node, port, rate, payload), (reader node, port)
            ("a", "/soak/a/out", rate, small_payload(self.rng)),
            ("c", "/soak/c/out", rate, small_payload(self.rng)),
            ("a", "/soak/a/big", 4, large_payload),
            ("c", "/soak/c/local", rate, small_payload(self.rng)),
        ]
        for node, port, per_second, payload in plan:
            writer = Writer(self.plexus, self.env(node), port, per_second, payload, self.work,
                            "writer" + port.replace("/", "-"))
            writer.node = node
            self.writers.append(writer)
        for node, port in [("b", "/soak/b/in"), ("b", "/soak/b/arbitrated"), ("c", "/soak/c/big"),
                           ("c", "/soak/c/localin")]:
            reader = Reader(self.plexus, self.env(node), port, self.work, "reader" + port.replace("/", "-"))
            reader.node = node
            self.readers.append(reader)
        for client in self.readers + self.writers:
            client.start()
        for client in self.readers + self.writers:
            self.wait_port(client.node, client.port)
        connections = [
            ("/soak/a/out", "/soak/b/in", "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.3"),
            ("/soak/a/out", "/soak/b/arbitrated", "tcp+recv.priority+tc.0.5+bs.1"),
            ("/soak/c/out", "/soak/b/arbitrated", "tcp+recv.priority+tc.0.5+bs.1+ex./soak/a/out:-1"),
            ("/soak/a/big", "/soak/c/big", "tcp"),
            ("/soak/c/local", "/soak/c/localin", ""),
        ]
        for source, destination, carrier in connections:
            args = ["connect", source, destination] + ([carrier] if carrier else []) + ["--persist"]
            result = self.cli("a", *args)
            if result.returncode != 0:
                raise RuntimeError("connect %s %s: %s" % (source, destination, result.stderr))

    # --- chaos -----------------------------------------------------------------------------------
    def listeners(self):
        return [self.names.info["names"]] + [d.info["address"] for d in self.daemons.values()]

    def chaos_step(self):
        action = self.rng.random()
        if action < 0.25:
            daemon = chaos.pick(self.rng, list(self.daemons.values()))
            daemon.kill()
            daemon.start()
            self.figures["daemon_kills"] += 1
        elif action < 0.35:
            self.names.kill()
            self.names.start()
            self.figures["names_kills"] += 1
        elif action < 0.55:
            client = chaos.pick(self.rng, self.writers + self.readers)
            client.kill()
            client.start()
            self.figures["client_kills"] += 1
        elif action < 0.85:
            for address in self.listeners():
                self.figures["garbage_bytes"] += chaos.send_garbage(address, self.rng)
                self.figures["garbage_connections"] += 1
        else:
            self.figures["flood_connects"] += chaos.flood_connects(chaos.pick(self.rng, self.listeners()), 200)

    def sample(self):
        for process in [self.names] + list(self.daemons.values()):
            rss = process.check()
            if rss:
                self.rss_samples.setdefault(process.name, []).append(rss)

    # --- the end ---------------------------------------------------------------------------------
    def drain(self):
        """Writers stop writing (their programs stay, ports open and connected); waits, with a
        deadline, until every port is empty, no link holds anything and the readers' counts stop
        moving; returns the stats then. The writers are finished afterwards."""
        for writer in self.writers:
            writer.pause()
        deadline = time.monotonic() + 60
        last = None
        stats = self.collect()
        while time.monotonic() < deadline:
            counts = [r.read for r in self.readers] + [s["ports"] and sum(p["written"] for p in s["ports"])
                                                       for s in stats.values()]
            depth = sum(p["depth"] for s in stats.values() for p in s["ports"])
            queued = sum(o.get("queued", 0) for s in stats.values() for p in s["ports"] for o in p.get("outgoing", []))
            if depth == 0 and queued == 0 and counts == last:
                return stats
            last = counts
            time.sleep(0.5)  # a poll interval, bounded by the deadline above
            stats = self.collect()
        return stats

    def collect(self):
        stats = {}
        for node in self.daemons:
            result = self.cli(node, "stats", "--json")
            if result.returncode == 0:
                stats[node] = json.loads(result.stdout)
        return stats

    def client_balances(self, stats):
        """Clients that started after the last start of their daemon saw what it counted: a writer
        handed its port as many lines as the port says were written, a reader printed as many as
        the port says it delivered."""
        checked, problems = 0, []
        ports = {(node, p["name"]): p for node, s in stats.items() for p in s["ports"]}
        views = [(w, "written", w.sent, "writer %s: handed %d lines, port written %d") for w in self.writers]
        views += [(r, "delivered", r.read, "reader %s: printed %d, port delivered %d") for r in self.readers]
        for client, counter, seen, text in views:
            port = ports.get((client.node, client.port))
            if port is None or client.started_at < self.daemons[client.node].started_at:
                continue
            checked += 1
            if port[counter] != seen:
                problems.append(text % (client.port, seen, port[counter]))
        return checked, problems

    def run(self):
        started = time.monotonic()
        self.start_names()
        for node in ("a", "b", "c"):
            self.start_daemon(node)
        idle = {n: d.check() for n, d in self.daemons.items()}
        self.start_traffic()
        chaos_until = started + self.args.seconds
        next_chaos = time.monotonic() + 2
        while time.monotonic() < chaos_until:
            self.sample()
            if time.monotonic() >= next_chaos:
                self.chaos_step()
                next_chaos = time.monotonic() + self.rng.uniform(0.5, 2.0)
            time.sleep(0.25)  # the loop's pace
        # Calm: traffic without chaos, so that every connection is back and flowing. Every client is
        # replaced first, so that each has lived only with the daemons as they are now and its own
        # count can be checked against the daemon's.
        for client in self.writers + self.readers:
            client.kill()
            client.start()
        calm_until = time.monotonic() + self.args.calm
        while time.monotonic() < calm_until:
            self.sample()
            time.sleep(0.25)
        stats = self.drain()
        for writer in self.writers:
            writer.finish()
        self.sample()
        checked, problems = accounting.check(stats)
        checked["clients"], client_problems = self.client_balances(stats)
        problems += client_problems
        final = {n: d.check() for n, d in self.daemons.items()}
        for reader in self.readers:
            reader.stop()
        for daemon in self.daemons.values():
            daemon.stop()
        self.names.stop()
        return self.report(started, stats, idle, final, checked, problems)

    def report(self, started, stats, idle, final, checked, problems):
        written = sum(w.sent_total for w in self.writers)
        read = sum(r.read_total for r in self.readers)
        shm = {n: s.get("daemon", {}).get("shm_passed", 0) + s.get("daemon", {}).get("shm_copied", 0)
               for n, s in stats.items()}
        most = {n: d.rss_most for n, d in self.daemons.items()}
        bound = self.args.rss_bound_mib * 1024
        over = [n for n, kib in most.items() if kib > bound]
        print("soak: %.0f s (%d s of chaos, then calm and drain), seed %d" % (time.monotonic() - started,
                                                                           self.args.seconds, self.args.seed))
        print("  messages: %d lines handed to writers, %d printed by readers (clients killed mid-stream lose"
              " what they held)" % (written, read))
        print("  chaos: %d daemon kills, %d name-server kills, %d client kills, %d garbage connections"
              " (%d bytes, TCP and UDP), %d flood connects" % (
                  self.figures["daemon_kills"], self.figures["names_kills"], self.figures["client_kills"],
                  self.figures["garbage_connections"], self.figures["garbage_bytes"], self.figures["flood_connects"]))
        print("  balances: %d checked (%s), %d broken" % (
            sum(checked.values()), ", ".join("%s %d" % item for item in checked.items()), len(problems)))
        for problem in problems:
            print("    BROKEN " + problem)
        print("  daemons' RSS KiB (idle at start / most while running / at the end): " + ", ".join(
            "%s %s/%s/%s" % (n, idle.get(n), most[n], final.get(n)) for n in sorted(most)))
        print("  bound %d MiB: %s" % (self.args.rss_bound_mib, "held" if not over else "EXCEEDED by " + ", ".join(over)))
        print("  shared memory: large payloads passed or copied per daemon (this incarnation): %s" % shm)
        print("  crashes: %d" % len(self.crashes))
        for crash in self.crashes:
            print("    CRASH " + crash)
        ok = not problems and not over and not self.crashes
        print("soak: " + ("PASSED" if ok else "FAILED") + "; logs in " + self.work)
        return ok


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("seconds", type=int, help="seconds of chaos")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rate", type=float, default=200.0, help="small messages per second per writer")
    parser.add_argument("--calm", type=float, default=10.0, help="seconds of traffic without chaos at the end")
    parser.add_argument("--rss-bound-mib", type=int, default=128, help="no daemon may exceed this resident size")
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--keep", action="store_true", help="keep the logs even when it passes")
    args = parser.parse_args()
    soak = Soak(args)
    try:
        ok = soak.run()
    finally:
        for client in soak.writers + soak.readers:
            if client.process and client.process.poll() is None:
                client.process.kill()
        for process in [soak.names] + list(soak.daemons.values()):
            if process and process.process and process.process.poll() is None:
                process.process.kill()
    if ok and not args.keep:
        shutil.rmtree(soak.work, ignore_errors=True)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
