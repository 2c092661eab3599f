-- Rate logger (monitor paper: watch a connection without touching it). Counts messages and
-- bytes; every `every` seconds logs the rate to the daemon log and, with `port`, publishes it.
--   tcp+recv.portmonitor+type.lua+file.rate_logger+every.1+port./rates
-- Options: every (s, default 1), port (optional).

local every, port
local messages, bytes = 0, 0
local window_messages, window_bytes = 0, 0
local window_start

PortMonitor.create = function(options)
    every = tonumber(options.every or "1") or 1
    port = options.port
    window_start = PortMonitor.now()
    PortMonitor.setTrigInterval(every)
    return true
end

PortMonitor.accept = function(msg)
    messages = messages + 1
    bytes = bytes + msg.size
    window_messages = window_messages + 1
    window_bytes = window_bytes + msg.size
    return true
end

PortMonitor.trig = function()
    local now = PortMonitor.now()
    local elapsed = now - window_start
    local report = {
        messages_per_s = window_messages / elapsed,
        bytes_per_s = window_bytes / elapsed,
        total_messages = messages,
    }
    print(string.format("%.1f msg/s, %.0f B/s, %d messages in all", report.messages_per_s,
        report.bytes_per_s, messages))
    if port then
        PortMonitor.publish(port, report)
    end
    window_messages, window_bytes, window_start = 0, 0, now
end

PortMonitor.getparam = function()
    return { messages = messages, bytes = bytes, every = every }
end
