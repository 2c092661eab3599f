-- Workspace guard (monitor paper: keep a manipulator's targets inside its reachable box).
-- A position is a map {x=, y=, z=}; positions outside the box are dropped.
--   tcp+recv.portmonitor+type.lua+file.workspace+xmin.-0.5+xmax.0.5+ymin.-0.5+ymax.0.5+zmin.0+zmax.1
-- Options: xmin xmax ymin ymax zmin zmax (a missing bound does not limit that side).

local box = {}

PortMonitor.create = function(options)
    for _, key in ipairs({ "xmin", "xmax", "ymin", "ymax", "zmin", "zmax" }) do
        if options[key] ~= nil then
            box[key] = tonumber(options[key])
            if box[key] == nil then
                print(key .. " must be a number, got " .. options[key])
                return false
            end
        end
    end
    return true
end

local function inside(value, low, high)
    if type(value) ~= "number" then
        return low == nil and high == nil
    end
    return (low == nil or value >= low) and (high == nil or value <= high)
end

PortMonitor.accept = function(msg)
    local p = msg.data
    if type(p) ~= "table" then
        return false
    end
    return inside(p.x, box.xmin, box.xmax) and inside(p.y, box.ymin, box.ymax) and inside(p.z, box.zmin, box.zmax)
end

PortMonitor.getparam = function()
    return box
end
