-- The selector connection of YARP's arbitration example, in its style: its own data is never
-- delivered (constraint false), and every message it carries switches the selection between the
-- two cameras by setting one event and removing the other.
require("yarp")

PortMonitor.create = function(options)
    PortMonitor.setConstraint("false")
    line_next = true
    return true
end

PortMonitor.destroy = function()
    PortMonitor.unsetEvent("e_line_selected")
    PortMonitor.unsetEvent("e_ball_selected")
end

PortMonitor.accept = function(thing)
    print("selector switched at " .. yarp.Time_now())
    if line_next then
        PortMonitor.setEvent("e_line_selected")
        PortMonitor.unsetEvent("e_ball_selected")
    else
        PortMonitor.setEvent("e_ball_selected")
        PortMonitor.unsetEvent("e_line_selected")
    end
    line_next = not line_next
    return true
end
