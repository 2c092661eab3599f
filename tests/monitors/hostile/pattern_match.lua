-- Attacks: string.match with captures and nested lazy repetitions on a large subject.
-- Expect: timeout
-- The sandbox's matcher charges each step: stopped at the time budget, the message dropped.
PortMonitor.accept = function(msg)
    return string.match(string.rep("ab", 20000), "(.-)(.-)(.-)(.-)c") ~= nil
end
