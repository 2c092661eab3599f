-- Codec pair (monitor paper: compress on the sending side, decompress on the receiving side,
-- transparently to both components). One script for both sides; options.side says which.
-- An array of numbers (a laser scan, say) travels as packed 32-bit floats: half the bytes of
-- CBOR doubles. Anything else passes through untouched.
--   tcp+send.portmonitor+type.lua+file.codec+recv.portmonitor+type.lua+file.codec

local side

PortMonitor.create = function(options)
    side = options.side
    return true
end

local function is_number_array(value)
    if type(value) ~= "table" or #value == 0 then
        return false
    end
    for i = 1, #value do
        if type(value[i]) ~= "number" then
            return false
        end
    end
    return next(value, #value) == nil
end

local function encode(values)
    local parts = { string.pack("<c4I4", "PXF1", #values) }
    for i = 1, #values do
        parts[#parts + 1] = string.pack("<f", values[i])
    end
    return table.concat(parts)
end

local function decode(bytes)
    local magic, count, position = string.unpack("<c4I4", bytes)
    if magic ~= "PXF1" then
        return nil
    end
    local values = {}
    for i = 1, count do
        values[i], position = string.unpack("<f", bytes, position)
    end
    return values
end

PortMonitor.update = function(msg)
    local data = msg.data
    if side == "send" then
        if is_number_array(data) then
            return encode(data)
        end
    elseif type(data) == "string" and #data >= 8 and data:sub(1, 4) == "PXF1" then
        return decode(data)
    end
    return msg
end
