-- Certainty filter (monitor paper: drop low-confidence detections before they reach the consumer).
-- A detection is a map with a `certainty` field in [0, 1]; anything below the threshold is dropped.
--   tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8
-- Options: threshold (default 0.5). Parameters: plexus param get|set SRC DST threshold=0.9

local threshold = 0.5

PortMonitor.create = function(options)
    if options.threshold then
        threshold = tonumber(options.threshold)
        if threshold == nil then
            print("threshold must be a number, got " .. options.threshold)
            return false
        end
    end
    return true
end

PortMonitor.accept = function(msg)
    local detection = msg.data
    if type(detection) ~= "table" or type(detection.certainty) ~= "number" then
        return false
    end
    return detection.certainty >= threshold
end

PortMonitor.getparam = function()
    return { threshold = threshold }
end

PortMonitor.setparam = function(params)
    if params.threshold ~= nil then
        threshold = tonumber(params.threshold) or threshold
    end
end
