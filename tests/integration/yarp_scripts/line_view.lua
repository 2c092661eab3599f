-- As ball_view.lua, for the line camera.
require("yarp")

PortMonitor.create = function(options)
    PortMonitor.setConstraint("e_line_selected")
    return true
end
