#include "compression.hpp"

#include <zstd.h>

#include <algorithm>
#include <memory>

namespace plexus::mcap {

namespace {

struct ContextDeleter {
    void operator()(ZSTD_CCtx* context) const { ZSTD_freeCCtx(context); }
    void operator()(ZSTD_DCtx* context) const { ZSTD_freeDCtx(context); }
};

}  // namespace

proto::Status zstd_compress(proto::ByteView input, int level, proto::Bytes& out) {
    out.resize(ZSTD_compressBound(input.size()));
    // One context per call: chunks are megabytes, so making a context is a small part of the cost.
    const std::unique_ptr<ZSTD_CCtx, ContextDeleter> context(ZSTD_createCCtx());
    if (!context)
        return proto::Error{"zstd: cannot allocate a compression context"};
    const std::size_t size =
        ZSTD_compressCCtx(context.get(), out.data(), out.size(), input.data(), input.size(), level);
    if (ZSTD_isError(size))
        return proto::Error{std::string("zstd: ") + ZSTD_getErrorName(size)};
    out.resize(size);
    return proto::Ok{};
}

proto::Status zstd_decompress(proto::ByteView input, std::uint64_t expected_size, proto::Bytes& out) {
    const std::unique_ptr<ZSTD_DCtx, ContextDeleter> context(ZSTD_createDCtx());
    if (!context)
        return proto::Error{"zstd: cannot allocate a decompression context"};
    // One byte beyond the declared size lets us notice data that decompresses to more.
    const std::uint64_t limit = expected_size + 1;
    out.clear();
    ZSTD_inBuffer in{input.data(), input.size(), 0};
    std::size_t produced = 0;
    while (true) {
        if (produced == out.size()) {
            if (out.size() >= limit)
                break;
            const std::uint64_t grown = std::max<std::uint64_t>(out.size() * 2, 64 * 1024);
            out.resize(static_cast<std::size_t>(std::min(limit, grown)));
        }
        ZSTD_outBuffer buffer{out.data(), out.size(), produced};
        const std::size_t consumed_before = in.pos;
        const std::size_t hint = ZSTD_decompressStream(context.get(), &buffer, &in);
        if (ZSTD_isError(hint))
            return proto::Error{std::string("zstd: ") + ZSTD_getErrorName(hint)};
        const bool progressed = buffer.pos > produced || in.pos > consumed_before;
        produced = buffer.pos;
        if (in.pos == in.size && hint == 0)
            break;  // every frame is complete
        // With room left in the output and nothing left to read, the decoder wants more input.
        if (in.pos == in.size && buffer.pos < buffer.size)
            return proto::Error{"the compressed records end inside a zstd frame"};
        if (!progressed)
            return proto::Error{"zstd made no progress"};
    }
    if (produced != expected_size) {
        return proto::Error{"the records decompress to " +
                            (produced > expected_size ? "more than " + std::to_string(expected_size)
                                                      : std::to_string(produced)) +
                            " bytes, the chunk declares " + std::to_string(expected_size)};
    }
    out.resize(produced);
    return proto::Ok{};
}

}  // namespace plexus::mcap
