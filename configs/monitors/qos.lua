-- Quality of service (monitor paper: notice that a source went silent and tell a coordinator).
-- Every `period` seconds, trig checks when the last message came; after `timeout` seconds of
-- silence it publishes {event="e_qos_not_ok"} on `port`, and {event="e_qos_ok"} once data flows
-- again. A coordinator (or `plexus read`) connects to that port like to any other; the port
-- exists from the moment the connection is made (create publishes the initial "ok").
--   tcp+recv.portmonitor+type.lua+file.qos+timeout.0.5+port./camera/qos
-- Options: timeout (s, default 1), period (s, default timeout/5), port (default /qos:event).
-- With `event.NAME` (recv side) it also keeps the event NAME in the input port's container while
-- the source is silent, so a backup source's constraint (`constraint.NAME`) can let it through:
--   tcp+recv.portmonitor+type.lua+file.qos+timeout.0.5+event.e_qos_not_ok+constraint.not e_qos_not_ok

local timeout, period, port, event
local last_seen
local silent = false

PortMonitor.create = function(options)
    timeout = tonumber(options.timeout or "1") or 1
    period = tonumber(options.period or tostring(timeout / 5)) or timeout / 5
    port = options.port or "/qos:event"
    event = options.event
    last_seen = PortMonitor.now()
    PortMonitor.setTrigInterval(period)
    PortMonitor.publish(port, { event = "e_qos_ok", source = options.source })
    return true
end

PortMonitor.accept = function(msg)
    last_seen = PortMonitor.now()
    if silent then
        silent = false
        if event then PortMonitor.unsetEvent(event) end
        PortMonitor.publish(port, { event = "e_qos_ok", source = msg.source })
    end
    return true
end

PortMonitor.trig = function()
    local quiet_for = PortMonitor.now() - last_seen
    if not silent and quiet_for > timeout then
        silent = true
        if event then PortMonitor.setEvent(event) end
        PortMonitor.publish(port, { event = "e_qos_not_ok", silent_for = quiet_for })
    end
end

PortMonitor.getparam = function()
    return { timeout = timeout, period = period, port = port, silent = silent }
end
