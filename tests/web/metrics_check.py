#!/usr/bin/python3
"""Checks plexusd's /metrics against `plexus stats --json` taken at the same quiet moment.

    metrics_check.py METRICS_FILE STATS_JSON_FILE

The metrics must parse with python3-prometheus-client's text parser, and every counter and gauge
of the stats document must be there with the same value: per port (plexus_port_*), per
connection out (plexus_outgoing_*) and in (plexus_inbound_*), per monitor (plexus_monitor_*), and
the daemon's (plexus_daemon_*). Left out: the daemon's `sessions`, `sessions_accepted` and `ring_sessions`, which
the CLI's own session changes between the two requests. Exit 0 when they agree; else every
difference is printed and the exit status is 1.
"""
import json
import sys

from prometheus_client.parser import text_string_to_metric_families

GAUGES = {'capacity', 'depth', 'bytes', 'queued', 'sessions', 'shm_bytes', 'shm_regions', 'shm_slots',
          'memory_bytes', 'quarantined', 'monitors_inline', 'udp_reassembly_bytes', 'calls_outstanding', 'served'}
CHANGED_BY_THE_CLI = {'sessions', 'sessions_accepted', 'ring_sessions'}


def samples(text):
    found = {}
    families = 0
    for family in text_string_to_metric_families(text):
        families += 1
        for sample in family.samples:
            key = (sample.name, tuple(sorted(sample.labels.items())))
            found[key] = sample.value
    return found, families


def expected(stats):
    """(metric name, labels) -> value for every number of the stats document."""
    node = stats['node']
    want = {}

    def numbers(prefix, obj, labels, skip=()):
        for field, value in obj.items():
            if field in skip or isinstance(value, (dict, list, str)) or value is None:
                continue
            gauge = field in GAUGES or isinstance(value, bool)
            name = f'{prefix}_{field}' + ('' if gauge else '_total')
            want[(name, tuple(sorted(labels.items())))] = float(value)

    def monitors(entry, labels):
        for monitor in entry.get('monitors', []):
            own = dict(labels, side=monitor['side'], script=monitor['script'], type=monitor['type'])
            numbers('plexus_monitor', monitor, own)

    numbers('plexus_daemon', stats['daemon'], {'node': node}, skip=CHANGED_BY_THE_CLI)
    for port in stats['ports']:
        labels = {'node': node, 'port': port['name']}
        numbers('plexus_port', port, labels)
        for out in port.get('outgoing', []):
            own = dict(labels, destination=out['destination'])
            numbers('plexus_outgoing', out, own)
            for carrier in ('udp', 'mcast'):
                if isinstance(out.get(carrier), dict):
                    numbers(f'plexus_outgoing_{carrier}', out[carrier], own)
            monitors(out, own)
        for inbound in port.get('inbound', []):
            own = dict(labels, source=inbound['source'])
            numbers('plexus_inbound', inbound, own)
            monitors(inbound, own)
    return want


def main():
    with open(sys.argv[1]) as f:
        metrics_text = f.read()
    with open(sys.argv[2]) as f:
        stats = json.load(f)
    got, families = samples(metrics_text)
    want = expected(stats)
    problems = []
    for key, value in sorted(want.items()):
        if key not in got:
            problems.append(f'missing: {key[0]}{dict(key[1])} (stats says {value})')
        elif got[key] != value:
            problems.append(f'differs: {key[0]}{dict(key[1])}: metrics {got[key]}, stats {value}')
    for problem in problems:
        print(problem)
    print(f'metrics_check: {families} families, {len(got)} samples, {len(want)} compared with stats, '
          f'{len(problems)} problems')
    return 1 if problems or len(want) < 10 else 0


if __name__ == '__main__':
    sys.exit(main())
