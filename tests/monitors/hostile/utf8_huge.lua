-- Attacks: utf8.len and utf8.offset walking a multi-megabyte string, again and again.
-- Expect: timeout
-- The sandbox's utf8 functions charge every character: stopped at the time budget.
PortMonitor.accept = function(msg)
    local s = string.rep("\u{20AC}", 2000000)
    while true do
        utf8.len(s)
        utf8.offset(s, 2000000)
    end
end
