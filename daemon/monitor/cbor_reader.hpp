#pragma once
// Reading CBOR as nlohmann's to_cbor writes it, straight into Lua values or a value at a time:
// msg.data's decoder (lua_value.cpp) and its lazy reads (lazy_map.cpp). Definite lengths only;
// `unusual` marks what it leaves to the careful decoder (proto/cbor.hpp) through json.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include <lua.hpp>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::monitor {

/// The head of a CBOR item: major type, additional info and argument (a length, a count, an
/// integer's magnitude, a float's bits, or the simple value of false/true/null/undefined).
struct CborHead {
    std::uint8_t major = 0;
    std::uint8_t info = 0;
    std::uint64_t argument = 0;
};

/// A cursor over CBOR bytes.
struct CborReader {
    const std::uint8_t* at;
    const std::uint8_t* end;
    bool unusual = false;

    std::size_t left() const { return static_cast<std::size_t>(end - at); }

    bool argument(std::uint8_t info, std::uint64_t& value) {
        if (info < 24) {
            value = info;
            return true;
        }
        if (info > 27) {
            unusual = true;  // indefinite length (31) or reserved
            return false;
        }
        const std::size_t n = std::size_t{1} << (info - 24);
        if (left() < n)
            return false;
        value = proto::read_big_endian(at, n);
        at += n;
        return true;
    }

    static double half_to_double(std::uint16_t half) {
        const int exponent = (half >> 10) & 0x1f;
        const int mantissa = half & 0x3ff;
        double value = 0;
        if (exponent == 0)
            value = std::ldexp(mantissa, -24);
        else if (exponent != 31)
            value = std::ldexp(mantissa + 1024, exponent - 25);
        else
            value = mantissa == 0 ? INFINITY : NAN;
        return (half & 0x8000) ? -value : value;
    }

    /// Steps over one value without decoding it; false on malformed or unusual input.
    bool skip(int depth) {
        if (at >= end || depth > 64)
            return false;
        const std::uint8_t initial = *at++;
        const std::uint8_t major = initial >> 5;
        const std::uint8_t info = initial & 0x1f;
        if (major == 7) {  // a simple value or a float: the head says how many bytes follow
            if (info < 24)
                return true;
            const std::size_t bytes = info <= 27 ? std::size_t{1} << (info - 24) : 0;
            if (bytes == 0 || left() < bytes) {
                unusual = info > 27;
                return false;
            }
            at += bytes;
            return true;
        }
        std::uint64_t n = 0;
        if (!argument(info, n))
            return false;
        switch (major) {
            case 0:
            case 1:
                return true;
            case 2:
            case 3:
                if (n > left())
                    return false;
                at += n;
                return true;
            case 4:
            case 5: {
                const std::uint64_t items = major == 5 ? 2 * n : n;
                if (items > left())
                    return false;
                for (std::uint64_t i = 0; i < items; ++i) {
                    if (!skip(depth + 1))
                        return false;
                }
                return true;
            }
            case 6:
                return skip(depth);
            default:
                return false;
        }
    }

    /// Reads the head of the next item; false when cut short, of indefinite length or reserved.
    bool head(CborHead& out) {
        if (at >= end)
            return false;
        const std::uint8_t initial = *at++;
        out.major = initial >> 5;
        out.info = initial & 0x1f;
        if (out.major == 7 && out.info >= 20 && out.info <= 23) {
            out.argument = out.info;
            return true;
        }
        return argument(out.info, out.argument);
    }

    /// Pushes one value; false (nothing pushed) on malformed or unusual input. Raises a Lua error
    /// only for memory.
    bool push(lua_State* L, int depth);
};

}  // namespace plexus::daemon::monitor
