-- Attacks: compiling a 2 MB chunk with load (the compiler runs no Lua instruction).
-- Expect: timeout
-- The chunk reaches the compiler 4 KiB at a time, each piece charged: stopped at the budget.
PortMonitor.accept = function(msg)
    local f = load("return " .. string.rep("1+", 1000000) .. "1")
    return f ~= nil
end
