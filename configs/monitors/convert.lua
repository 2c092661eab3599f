-- Format converter (monitor paper: adapt one component's output to what another expects,
-- without changing either). A detector writes {u=, v=, certainty=}; the gaze controller wants
-- {target={u, v}, frame=FRAME, weight=certainty}.
--   tcp+recv.portmonitor+type.lua+file.convert+frame.camera_left

local frame = "camera"

PortMonitor.create = function(options)
    frame = options.frame or frame
    return true
end

PortMonitor.update = function(msg)
    local d = msg.data
    if type(d) ~= "table" or d.u == nil or d.v == nil then
        return msg -- not a detection: pass it on as it is
    end
    return { target = { d.u, d.v }, frame = frame, weight = d.certainty or 1.0 }
end
