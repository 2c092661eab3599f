-- A selector in the style of YARP's arbitration example, runnable on YARP and on Plexus: an
-- auxiliary connection whose own data never reaches the port (its constraint is `false`, set in
-- create) and whose every message passes the turn to the next of the events it was given.
--
--   plexus connect /selector/out /view/in \
--       tcp+recv.portmonitor+type.lua+file.yarp_selector+events.e_ball,e_line
--   plexus connect /ball/out /view/in tcp+recv.portmonitor+constraint.e_ball
--   plexus connect /line/out /view/in tcp+recv.portmonitor+constraint.e_line
--
-- It shows the three calls a monitor has for its rule and the shared events: setConstraint
-- (in create, the way the monitor paper's listing sets its rule), getConstraint and hasEvent.
require("yarp")

local choices = {}
local turn = 0

PortMonitor.create = function(options)
    for name in string.gmatch(options.events or "e_first,e_second", "[^,]+") do
        choices[#choices + 1] = name
    end
    PortMonitor.setConstraint("false")
    yarp.log("selector over " .. table.concat(choices, ", ") .. ", own rule: " .. PortMonitor.getConstraint())
    return true
end

PortMonitor.accept = function(msg)
    -- Whatever another monitor did to the events, exactly one choice holds after this message.
    turn = turn % #choices + 1
    for i, name in ipairs(choices) do
        if i == turn then
            PortMonitor.setEvent(name)
        elseif PortMonitor.hasEvent(name) then
            PortMonitor.unsetEvent(name)
        end
    end
    return true
end

PortMonitor.destroy = function()
    for _, name in ipairs(choices) do
        PortMonitor.unsetEvent(name)
    end
end
