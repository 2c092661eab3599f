-- Attacks: a finalizer that never ends. Lua 5.4 runs __gc metamethods with the debug hooks off, so
-- the budget's instruction hook would never fire inside one; garbage made on every call drives the
-- collector to run it.
-- Expect: error
-- The sandbox's setmetatable refuses a metatable with a __gc field (docs/MONITORS.md).
PortMonitor.accept = function(msg)
    setmetatable({}, {__gc = function() while true do end end})
    for i = 1, 100000 do local garbage = {i} end
    return true
end
