-- Certainty filter (monitor paper: drop low-confidence detections before they reach the consumer).
-- A detection is a map with a `certainty` field in [0, 1]; anything below the threshold is dropped.
--   tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8
-- Options: threshold (default 0.5). Parameters: plexus param get|set SRC DST threshold=0.9
--
-- With `event.NAME` it also raises an event in the input port's container (arbitration, recv
-- side only): NAME is set while detections reach the threshold and unset when one falls below;
-- with `lifetime.SECONDS` the event also expires unless a new good detection refreshes it.
--   tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.7+event.e_template_ok+lifetime.0.5
-- With `keep` it only raises the event and passes every detection on, leaving the choice to
-- the constraints.

local threshold = 0.5
local event = nil
local lifetime = nil
local keep = false

PortMonitor.create = function(options)
    if options.threshold then
        threshold = tonumber(options.threshold)
        if threshold == nil then
            print("threshold must be a number, got " .. options.threshold)
            return false
        end
    end
    event = options.event
    if options.lifetime then
        lifetime = tonumber(options.lifetime)
        if lifetime == nil then
            print("lifetime must be a number of seconds, got " .. options.lifetime)
            return false
        end
    end
    keep = options.keep ~= nil
    return true
end

PortMonitor.accept = function(msg)
    local detection = msg.data
    local good = type(detection) == "table" and type(detection.certainty) == "number"
        and detection.certainty >= threshold
    if event then
        if good then
            PortMonitor.setEvent(event, lifetime)
        else
            PortMonitor.unsetEvent(event)
        end
    end
    return good or keep
end

PortMonitor.getparam = function()
    return { threshold = threshold, event = event, lifetime = lifetime }
end

PortMonitor.setparam = function(params)
    if params.threshold ~= nil then
        threshold = tonumber(params.threshold) or threshold
    end
end
