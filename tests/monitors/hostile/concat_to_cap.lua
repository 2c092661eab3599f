-- Attacks: table.concat of a table of large strings, its result past the memory cap.
-- Expect: out_of_memory
-- The allocator refuses growth past the cap: "not enough memory", counted as out_of_memory.
PortMonitor.accept = function(msg)
    local piece = string.rep("x", 1 << 20)
    local t = {}
    for i = 1, 64 do t[i] = piece end
    return #table.concat(t) > 0
end
