-- Attacks: string.format with the widest conversions Lua allows, thousands of them per
-- call, in a loop (a width over 99 is refused by Lua itself, which is checked first).
-- Expect: timeout
-- The sandbox feeds the format to Lua's in bounded pieces and charges each: stopped at the
-- time budget.
PortMonitor.accept = function(msg)
    assert(not pcall(string.format, "%999999d", 1))
    local values = {}
    for i = 1, 2000 do values[i] = 1e308 end
    local format = string.rep("%99.99f", 2000)
    while true do string.format(format, table.unpack(values)) end
end
