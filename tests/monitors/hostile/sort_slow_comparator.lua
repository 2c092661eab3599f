-- Attacks: table.sort with a comparator that spins on every comparison.
-- Expect: timeout
-- The comparator is Lua code, so the hook fires in it; the sort itself charges each comparison
-- round. Stopped at the time budget; a pcall around the sort cannot catch the budget error.
PortMonitor.accept = function(msg)
    local t = {}
    for i = 1, 10000 do t[i] = (i * 7919) % 10007 end
    pcall(table.sort, t, function(a, b)
        for _ = 1, 1000 do end
        return a < b
    end)
    return true
end
