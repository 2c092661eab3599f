-- A condition on one field of each message, turned into an event and/or a filter. It knows
-- nothing of what the field means: the fetch-and-carry application (configs/apps/fetch.json)
-- uses it for "the object is held" (touch), "the hand is at the object" and "the hand is at the
-- person" (proximity), and to let only "held" touch messages stimulate an auxiliary connection.
--
--   recv.portmonitor+type.lua+file.when+field.held+equals.true+event.e_held
--   recv.portmonitor+type.lua+file.when+field.object+below.0.03+event.e_at_object
--   recv.portmonitor+type.lua+file.when+field.held+equals.true+filter
--
-- Options:
--   field.NAME      the key of the message's map to look at (required)
--   equals.VALUE    holds when the field equals VALUE (true, false, a number or a string)
--   below.X / above.X  holds when the field is a number < X / > X (both may be given)
--   event.NAME      set NAME in the input port's event container while the condition holds,
--                   unset it on the first message where it does not
--   lifetime.S      the event also expires S seconds after the last message that held (so a
--                   sensor that stops publishing does not leave it set forever); default 1
--   filter          accept only the messages where the condition holds (default: accept all,
--                   the monitor then only raises the event)
-- A message without the field, or with a field of another type, does not hold.

local field = nil
local equals = nil
local below = nil
local above = nil
local event = nil
local lifetime = 1.0
local filter = false

local function parse_value(text)
    if text == "true" then return true end
    if text == "false" then return false end
    return tonumber(text) or text
end

local function number_option(options, key)
    if options[key] == nil then
        return nil, true
    end
    local value = tonumber(options[key])
    if value == nil then
        print(key .. " must be a number, got " .. options[key])
        return nil, false
    end
    return value, true
end

PortMonitor.create = function(options)
    field = options.field
    if field == nil or field == "" then
        print("when: field.NAME is required")
        return false
    end
    if options.equals ~= nil then
        equals = parse_value(options.equals)
    end
    local ok
    below, ok = number_option(options, "below")
    if not ok then return false end
    above, ok = number_option(options, "above")
    if not ok then return false end
    local life
    life, ok = number_option(options, "lifetime")
    if not ok then return false end
    lifetime = life or lifetime
    if equals == nil and below == nil and above == nil then
        print("when: give equals.VALUE, below.X or above.X")
        return false
    end
    event = options.event
    filter = options.filter ~= nil
    return true
end

local function holds(data)
    if type(data) ~= "table" then
        return false
    end
    local value = data[field]
    if equals ~= nil and value ~= equals then
        return false
    end
    if below ~= nil and not (type(value) == "number" and value < below) then
        return false
    end
    if above ~= nil and not (type(value) == "number" and value > above) then
        return false
    end
    return value ~= nil
end

PortMonitor.accept = function(msg)
    local yes = holds(msg.data)
    if event then
        if yes then
            PortMonitor.setEvent(event, lifetime)
        else
            PortMonitor.unsetEvent(event)
        end
    end
    return yes or not filter
end

PortMonitor.getparam = function()
    return { field = field, equals = equals, below = below, above = above, event = event,
             lifetime = lifetime, filter = filter }
end
