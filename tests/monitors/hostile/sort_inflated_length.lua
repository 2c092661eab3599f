-- Attacks: table.sort over a length a __len metamethod makes 2^31 - 2, with reads and writes
-- through C functions (rawlen, rawequal) that run no Lua instruction: Lua's own sort would run
-- for hours in C.
-- Expect: timeout
-- The sandbox's sort charges each step: stopped at the time budget.
PortMonitor.accept = function(msg)
    local t = setmetatable({}, {
        __len = function() return 2 ^ 31 - 2 end,
        __index = rawlen,
        __newindex = rawequal,
    })
    table.sort(t)
    return true
end
