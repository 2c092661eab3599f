"""Do the counters add up? Checked on every live daemon once traffic has stopped and drained.

The balances (each counter as `plexus stats --json` names it):
  port:        received == delivered + dropped_queue + depth
  connection into a port (inlet):
               received == accepted + dropped_by_accept
               accepted == delivered + dropped_by_constraint + dropped_by_priority + dropped_by_queue
  connection, both ends live (its two halves were made together, so their counters start together):
               source sent - dropped_by_monitor - queued == destination inlet received
  clients that lived through the whole life of their port (no daemon restart since they started):
               lines a writer handed to `plexus write` == port written
               port delivered == lines the reader printed
"""


def port_balance(port):
    left = port["received"]
    right = port["delivered"] + port["dropped_queue"] + port["depth"]
    return left == right, "%s: received %d != delivered %d + dropped_queue %d + depth %d" % (
        port["name"], left, port["delivered"], port["dropped_queue"], port["depth"])


def inlet_balances(port):
    problems = []
    for inlet in port.get("inbound", []):
        tag = "%s <- %s" % (port["name"], inlet["source"])
        if inlet["received"] != inlet["accepted"] + inlet["dropped_by_accept"]:
            problems.append("%s: received %d != accepted %d + dropped_by_accept %d" % (
                tag, inlet["received"], inlet["accepted"], inlet["dropped_by_accept"]))
        passed = (inlet["delivered"] + inlet["dropped_by_constraint"] + inlet["dropped_by_priority"] +
                  inlet["dropped_by_queue"])
        if inlet["accepted"] != passed:
            problems.append("%s: accepted %d != delivered %d + dropped by constraint %d / priority %d / queue %d" % (
                tag, inlet["accepted"], inlet["delivered"], inlet["dropped_by_constraint"],
                inlet["dropped_by_priority"], inlet["dropped_by_queue"]))
    return problems


def connection_balances(stats_by_node):
    """Matches every outgoing connection with the inlet of the same pair on the destination's
    daemon; returns (checked, problems)."""
    inlets = {}
    for stats in stats_by_node.values():
        for port in stats["ports"]:
            for inlet in port.get("inbound", []):
                inlets[(inlet["source"], port["name"])] = inlet
    checked, problems = 0, []
    for stats in stats_by_node.values():
        for port in stats["ports"]:
            for out in port.get("outgoing", []):
                inlet = inlets.get((port["name"], out["destination"]))
                if inlet is None:
                    continue
                checked += 1
                passed = out["sent"] - out["dropped_by_monitor"] - out.get("queued", 0)
                if passed != inlet["received"]:
                    problems.append("%s -> %s: sent %d - dropped_by_monitor %d - queued %d != received %d there" % (
                        port["name"], out["destination"], out["sent"], out["dropped_by_monitor"],
                        out.get("queued", 0), inlet["received"]))
    return checked, problems


def check(stats_by_node):
    """All the daemon-side balances; returns ({kind: number checked}, problems)."""
    checked = {"ports": 0, "inlets": 0, "connections": 0}
    problems = []
    for stats in stats_by_node.values():
        for port in stats["ports"]:
            ok, text = port_balance(port)
            checked["ports"] += 1
            if not ok:
                problems.append(text)
            checked["inlets"] += len(port.get("inbound", []))
            problems += inlet_balances(port)
    checked["connections"], link_problems = connection_balances(stats_by_node)
    return checked, problems + link_problems
