-- Written the way YARP's arbitration example writes its monitors: the module first, the rule set
-- in create. Passes the ball camera's images while the selector has picked the ball.
require("yarp")

PortMonitor.create = function(options)
    PortMonitor.setConstraint("e_ball_selected")
    return true
end
