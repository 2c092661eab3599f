-- Attacks: string.gmatch, each iteration a backtracking search over a large subject.
-- Expect: timeout
-- The sandbox's matcher charges each step: stopped at the time budget, the message dropped.
PortMonitor.accept = function(msg)
    for _ in string.gmatch(string.rep("a", 30000), "a-a-a-b") do end
    return true
end
