-- Attacks: a loop that spends the whole budget on every message (and never ends).
-- Expect: timeout
-- The instruction hook stops it at the time budget; a pcall inside cannot swallow the error.
PortMonitor.accept = function(msg)
    while true do
        pcall(function() while true do end end)
    end
end
