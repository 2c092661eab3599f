-- Attacks: table.move over 10^15 elements of an empty table: no memory is used, and Lua's own
-- move loops in C for days.
-- Expect: timeout
-- The sandbox's move charges each element: stopped at the time budget.
PortMonitor.accept = function(msg)
    table.move({}, 1, 1e15, 2)
    return true
end
