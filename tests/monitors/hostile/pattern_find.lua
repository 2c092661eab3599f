-- Attacks: string.find with a backtracking pattern on a large subject. Lua's own matcher runs
-- for minutes inside C, where the instruction hook never fires (this froze the whole daemon).
-- Expect: timeout
-- The sandbox's matcher charges each step: accept is stopped at its time budget and the message
-- is dropped.
PortMonitor.accept = function(msg)
    return string.find(string.rep("a", 30000), ".-.-.-b") ~= nil
end
