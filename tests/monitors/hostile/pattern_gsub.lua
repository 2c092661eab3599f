-- Attacks: string.gsub with optional items that backtrack exponentially on a large subject.
-- Expect: timeout
-- The sandbox's matcher charges each step: stopped at the time budget, the message dropped.
PortMonitor.accept = function(msg)
    local s = string.gsub(string.rep("a", 100000), string.rep("a?", 40) .. "b", "")
    return #s > 0
end
