"""The processes of a soak run: a name server, daemons, CLI writers and readers, each restartable.

A process that ends without the soak having killed it is a crash, recorded with how it ended.
"""
import json
import os
import signal
import subprocess
import threading
import time


def wait_for_file(path, process, seconds=20.0):
    deadline = time.monotonic() + seconds
    while not os.path.exists(path):
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError("%s did not become ready (exit %s)" % (path, process.poll()))
        time.sleep(0.02)


def rss_kib(pid):
    try:
        with open("/proc/%d/status" % pid) as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


class Managed:
    """One long-lived program (name server or daemon), started again after each kill."""

    def __init__(self, name, argv, ready, work, crashes):
        self.name, self.argv, self.ready, self.work = name, argv, ready, work
        self.crashes = crashes
        self.process = None
        self.starts = 0
        self.started_at = 0.0
        self.rss_most = 0
        self.info = {}

    def start(self):
        if os.path.exists(self.ready):
            os.remove(self.ready)
        log = open(os.path.join(self.work, "%s.%d.log" % (self.name, self.starts)), "w")
        self.process = subprocess.Popen(self.argv, stdout=log, stderr=subprocess.STDOUT)
        self.starts += 1
        wait_for_file(self.ready, self.process)
        self.info = json.load(open(self.ready))
        self.started_at = time.monotonic()

    def pin(self, flag, value):
        """From now on start with FLAG VALUE (the address the first start was given)."""
        index = self.argv.index(flag)
        self.argv[index + 1] = value

    def kill(self):
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()

    def check(self):
        """Records a crash if the process ended by itself; returns its RSS (KiB) or None."""
        if self.process.poll() is not None:
            self.crashes.append("%s ended by itself: exit %s (start %d)" % (self.name, self.process.returncode,
                                                                           self.starts))
            self.start()
            return None
        rss = rss_kib(self.process.pid)
        if rss:
            self.rss_most = max(self.rss_most, rss)
        return rss

    def stop(self):
        if self.process and self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.crashes.append("%s did not stop on SIGTERM within 10 s" % self.name)
                self.process.kill()


class Writer:
    """`plexus write PORT` fed numbered JSON lines by a thread at a steady pace."""

    def __init__(self, plexus, env, port, rate, payload, work, tag):
        self.plexus, self.env, self.port, self.rate, self.payload = plexus, env, port, rate, payload
        self.work, self.tag = work, tag
        self.process = None
        self.sent = 0        # lines handed to the current incarnation
        self.sent_total = 0
        self.incarnations = 0
        self.started_at = 0.0
        self.stopping = threading.Event()
        self.thread = None

    def start(self):
        log = open(os.path.join(self.work, "%s.%d.err" % (self.tag, self.incarnations)), "w")
        self.process = subprocess.Popen([self.plexus, "write", self.port], env=self.env, stdin=subprocess.PIPE,
                                        stdout=subprocess.DEVNULL, stderr=log, text=True, bufsize=1)
        self.incarnations += 1
        self.sent = 0
        self.started_at = time.monotonic()
        self.stopping = threading.Event()
        process, stopping = self.process, self.stopping
        self.thread = threading.Thread(target=self._feed, args=(process, stopping), daemon=True)
        self.thread.start()

    def _feed(self, process, stopping):
        pause = 1.0 / self.rate
        n = 0
        while not stopping.is_set() and process.poll() is None:
            n += 1
            try:
                process.stdin.write(self.payload(n) + "\n")
            except (BrokenPipeError, ValueError, OSError):
                return
            self.sent += 1
            self.sent_total += 1
            time.sleep(pause)  # the writer's pace, not a wait for an outcome

    def kill(self):
        self.stopping.set()
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()
        self.thread.join(timeout=5)

    def pause(self):
        """Stops handing lines to the program; its port stays open."""
        self.stopping.set()
        self.thread.join(timeout=5)

    def finish(self):
        """Ends the input: the CLI flushes what it holds and exits."""
        self.stopping.set()
        self.thread.join(timeout=5)
        try:
            self.process.stdin.close()
        except OSError:
            pass
        try:
            return self.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.process.kill()
            return None


class Reader:
    """`plexus read PORT --envelope`, its lines counted by a thread."""

    def __init__(self, plexus, env, port, work, tag, policy="strict"):
        self.plexus, self.env, self.port, self.work, self.tag, self.policy = plexus, env, port, work, tag, policy
        self.process = None
        self.read = 0
        self.read_total = 0
        self.incarnations = 0
        self.started_at = 0.0

    def start(self):
        log = open(os.path.join(self.work, "%s.%d.err" % (self.tag, self.incarnations)), "w")
        self.process = subprocess.Popen([self.plexus, "read", self.port, "--envelope", "--policy", self.policy,
                                         "--timeout", "100000"], env=self.env, stdout=subprocess.PIPE, stderr=log,
                                        text=True)
        self.incarnations += 1
        self.read = 0
        self.started_at = time.monotonic()
        threading.Thread(target=self._count, args=(self.process,), daemon=True).start()

    def _count(self, process):
        for _ in process.stdout:
            if process is self.process:
                self.read += 1
            self.read_total += 1

    def kill(self):
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()

    def stop(self):
        self.process.send_signal(signal.SIGTERM)
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
