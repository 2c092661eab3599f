-- Attacks: a plain (no pattern) string.find whose needle almost matches everywhere: memchr and
-- memcmp at every position, O(subject x needle) in C.
-- Expect: timeout
-- The search charges each comparison by the needle's size: stopped at the time budget.
PortMonitor.accept = function(msg)
    local subject = string.rep("a", 4000000)
    local needle = string.rep("a", 2000) .. "b"
    while true do string.find(subject, needle, 1, true) end
end
