-- Attacks: unbounded recursion (not a tail call), growing the Lua stack on every message.
-- Expect: error
-- Lua stops it at its stack limit ("stack overflow") or the memory cap stops it first; either
-- way accept fails, is counted as an error, and the message is dropped.
-- Known gap: the stack reaches the 16 MiB cap first, and the growth of a stack that large (copies,
-- then an emergency collection on the failing one) runs no instruction. Measured 9-15 ms per call
-- on a quiet machine, but 31-57 ms on the same machine under load (budget 20 ms): not reliably
-- within budget + 5 ms.
local function down(n)
    return 1 + down(n + 1)
end
PortMonitor.accept = function(msg)
    return down(1) > 0
end
