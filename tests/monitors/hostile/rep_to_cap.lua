-- Attacks: string.rep doubling a string up to and past the memory cap.
-- Expect: out_of_memory
-- The allocator refuses growth past the cap: accept fails with "not enough memory", counted as
-- out_of_memory; the state's memory stays under the cap.
PortMonitor.accept = function(msg)
    local s = "x"
    while true do s = string.rep(s, 2) end
end
