-- health: sets an event while a server's health stream says it is well (docs/CALLS.md).
--
-- On a connection from a server's health port into a service port (or a caller's port), usually
-- auxiliary, so that the health messages themselves are not delivered:
--     plexus connect /planner/a/health /nav/plan 'local+recv.portmonitor+type.lua+file.health+event.a_ok+aux'
-- Each message whose data is a map with `ok` true (or the value true) sets the event for
-- `lifetime` seconds (default 0.5): a server that stops publishing, or dies, loses it by itself.
-- Anything else unsets it at once. The connections to the servers then say which one takes calls:
--     plexus connect /nav/plan /planner/a 'local+send.portmonitor+constraint.a_ok'
--     plexus connect /nav/plan /planner/b 'local+send.portmonitor+constraint.not a_ok'

PortMonitor = PortMonitor or {}

local event
local lifetime = 0.5

function PortMonitor.create(options)
  event = options.event
  if event == nil or event == '' then
    print("health: say which event to set, with the key event.NAME")
    return false
  end
  if options.lifetime ~= nil then
    lifetime = tonumber(options.lifetime)
    if lifetime == nil or lifetime <= 0 then
      print("health: lifetime must be a number of seconds above 0, not " .. options.lifetime)
      return false
    end
  end
  return true
end

function PortMonitor.accept(msg)
  local data = msg.data
  local ok = data == true or (type(data) == 'table' and data.ok == true)
  if ok then
    PortMonitor.setEvent(event, lifetime)
  else
    PortMonitor.unsetEvent(event)
  end
  return true
end
