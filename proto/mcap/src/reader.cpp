#include "plexus/mcap/reader.hpp"

#include <algorithm>
#include <array>

#include "crc32.hpp"
#include "data_scan.hpp"
#include "encoding.hpp"
#include "format.hpp"
#include "input_source.hpp"
#include "record_codec.hpp"

namespace plexus::mcap {

namespace {

constexpr std::uint8_t opcode_of(format::Opcode opcode) {
    return static_cast<std::uint8_t>(opcode);
}

}  // namespace

Reader::Reader(std::unique_ptr<InputSource> source) : source_(std::move(source)) {}
Reader::Reader(Reader&&) noexcept = default;
Reader& Reader::operator=(Reader&&) noexcept = default;
Reader::~Reader() = default;

std::uint64_t Reader::file_size() const {
    return source_->size();
}

proto::Result<Reader> Reader::open(const std::string& path) {
    auto source = open_file_source(path);
    if (!source)
        return source.error();
    auto reader = open_source(std::move(*source));
    if (!reader)
        return proto::Error{path + ": " + reader.error().message};
    return reader;
}

proto::Result<Reader> Reader::open_bytes(proto::Bytes bytes) {
    return open_source(memory_source(std::move(bytes)));
}

proto::Result<Reader> Reader::open_source(std::unique_ptr<InputSource> source) {
    Reader reader(std::move(source));
    const InputSource& input = *reader.source_;
    const std::uint64_t size = input.size();

    std::array<std::uint8_t, format::magic.size()> magic{};
    if (size < magic.size() || !input.read(0, magic) || magic != format::magic)
        return proto::Error{"offset 0: not an MCAP file (bad magic)"};

    auto header = read_record_header(input, magic.size(), size, "file");
    if (!header)
        return truncation_error(input, magic.size());
    if (header->opcode != opcode_of(format::Opcode::header))
        return proto::Error{at_offset(magic.size()) + "the first record is a " +
                            std::string(format::opcode_name(header->opcode)) + " record, not a header"};
    if (header->length > format::max_summary)
        return proto::Error{at_offset(magic.size()) + "header record of " + std::to_string(header->length) +
                            " bytes exceeds this reader's limit"};
    proto::Bytes content;
    if (auto status = read_bytes(input, header->offset + format::record_header_size, header->length, content);
        !status)
        return status.error();
    if (auto status = parse_header(content, at_offset(magic.size()) + "header record", reader.profile_,
                                   reader.library_);
        !status)
        return status.error();
    reader.data_begin_ = header->end();

    // The end: footer record and closing magic. Without them the file was cut short.
    if (size - reader.data_begin_ < format::footer_and_magic_size)
        return truncation_error(input, magic.size());
    if (!input.read(size - magic.size(), magic) || magic != format::magic)
        return truncation_error(input, magic.size());
    reader.footer_offset_ = size - format::footer_and_magic_size;
    auto footer_header = read_record_header(input, reader.footer_offset_, size - magic.size(), "file");
    if (!footer_header || footer_header->opcode != opcode_of(format::Opcode::footer) ||
        footer_header->length != format::footer_content_size)
        return proto::Error{at_offset(reader.footer_offset_) + "no footer record before the closing magic"};
    if (auto status = read_bytes(input, reader.footer_offset_ + format::record_header_size,
                                 format::footer_content_size, content);
        !status)
        return status.error();
    auto footer = parse_footer(content, at_offset(reader.footer_offset_) + "footer record");
    if (!footer)
        return footer.error();

    if (footer->summary_start == 0) {
        reader.data_end_ = reader.footer_offset_;
        if (auto status = reader.scan_for_summary(); !status)
            return status.error();
        return reader;
    }
    if (footer->summary_start < reader.data_begin_ || footer->summary_start > reader.footer_offset_)
        return proto::Error{at_offset(reader.footer_offset_) + "footer: the summary start " +
                            std::to_string(footer->summary_start) + " is outside the file's records (" +
                            std::to_string(reader.data_begin_) + " to " +
                            std::to_string(reader.footer_offset_) + ")"};
    if (footer->summary_offset_start != 0 && (footer->summary_offset_start < footer->summary_start ||
                                              footer->summary_offset_start > reader.footer_offset_))
        return proto::Error{at_offset(reader.footer_offset_) + "footer: the summary offset start " +
                            std::to_string(footer->summary_offset_start) + " is outside the summary"};
    reader.data_end_ = footer->summary_start;

    // The summary, with the footer up to its CRC field, which the CRC covers.
    const std::uint64_t summary_length = reader.footer_offset_ - footer->summary_start;
    if (summary_length > format::max_summary)
        return proto::Error{at_offset(footer->summary_start) + "a summary of " +
                            std::to_string(summary_length) + " bytes exceeds this reader's limit"};
    proto::Bytes summary;
    if (auto status = read_bytes(input, footer->summary_start,
                                 summary_length + format::record_header_size + 16, summary);
        !status)
        return status.error();
    if (footer->summary_crc != 0) {
        const std::uint32_t actual = crc32(summary);
        if (actual != footer->summary_crc)
            return proto::Error{at_offset(footer->summary_start) + "summary CRC mismatch (the footer says " +
                                std::to_string(footer->summary_crc) + ", the bytes give " +
                                std::to_string(actual) + ")"};
    }
    summary.resize(static_cast<std::size_t>(summary_length));
    if (auto status = reader.read_summary_records(footer->summary_start, summary); !status)
        return status.error();
    reader.has_summary_ = true;
    return reader;
}

proto::Status Reader::read_summary_records(std::uint64_t summary_start, proto::ByteView summary) {
    bool has_statistics = false;
    std::uint32_t chunk_indexes = 0;
    std::vector<MetadataIndexFields> metadata_indexes;
    std::uint64_t position = 0;
    while (position < summary.size()) {
        const std::uint64_t offset = summary_start + position;
        const std::uint64_t left = summary.size() - position;
        if (left < format::record_header_size)
            return proto::Error{at_offset(offset) + "the summary ends inside a record header"};
        RecordHeader header{summary[position], position, load_u64(summary.data() + position + 1)};
        const std::string where =
            at_offset(offset) + std::string(format::opcode_name(header.opcode)) + " record";
        if (header.length > left - format::record_header_size)
            return proto::Error{where + ": its length " + std::to_string(header.length) +
                                " runs past the end of the summary"};
        const auto content = summary.subspan(static_cast<std::size_t>(position + format::record_header_size),
                                             static_cast<std::size_t>(header.length));
        switch (static_cast<format::Opcode>(header.opcode)) {
            case format::Opcode::schema: {
                auto schema = parse_schema(content, where);
                if (!schema)
                    return schema.error();
                if (schema->id != 0)  // id 0 is invalid, to be ignored (spec)
                    schemas_[schema->id] = std::move(*schema);
                break;
            }
            case format::Opcode::channel: {
                auto channel = parse_channel(content, where);
                if (!channel)
                    return channel.error();
                channels_[channel->id] = std::move(*channel);
                break;
            }
            case format::Opcode::statistics: {
                auto statistics = parse_statistics(content, where);
                if (!statistics)
                    return statistics.error();
                statistics_ = std::move(*statistics);
                has_statistics = true;
                break;
            }
            case format::Opcode::chunk_index: {
                auto index = parse_chunk_index(content, where);
                if (!index)
                    return index.error();
                if (index->chunk_start_offset < data_begin_ || index->chunk_start_offset > data_end_ ||
                    index->chunk_length > data_end_ - index->chunk_start_offset)
                    return proto::Error{where + ": it points outside the data section"};
                auto& channels = chunk_channels_[index->chunk_start_offset];
                for (const auto& [channel, message_index_offset] : index->message_index_offsets)
                    channels.insert(channel);
                ++chunk_indexes;
                break;
            }
            case format::Opcode::metadata_index: {
                auto index = parse_metadata_index(content, where);
                if (!index)
                    return index.error();
                if (index->offset < data_begin_ || index->offset > data_end_ ||
                    index->length > data_end_ - index->offset || index->length < format::record_header_size)
                    return proto::Error{where + ": it points outside the data section"};
                metadata_indexes.push_back(std::move(*index));
                break;
            }
            default:
                break;  // summary offsets, attachment indexes, records of later versions
        }
        position = header.end();
    }
    if (!has_statistics)
        statistics_.chunk_count = chunk_indexes;

    for (const auto& index : metadata_indexes) {
        const std::string where = at_offset(index.offset) + "metadata record";
        auto header =
            read_record_header(*source_, index.offset, index.offset + index.length, "metadata index's range");
        if (!header)
            return header.error();
        if (header->opcode != opcode_of(format::Opcode::metadata) ||
            header->end() != index.offset + index.length)
            return proto::Error{at_offset(index.offset) + "the metadata index named \"" + index.name +
                                "\" does not point at a metadata record of its length"};
        proto::Bytes content;
        if (auto status =
                read_bytes(*source_, index.offset + format::record_header_size, header->length, content);
            !status)
            return status;
        auto metadata = parse_metadata(content, where);
        if (!metadata)
            return metadata.error();
        if (metadata->name != index.name)
            return proto::Error{where + ": named \"" + metadata->name + "\", its index says \"" + index.name +
                                "\""};
        metadata_.push_back(std::move(*metadata));
    }
    return proto::Ok{};
}

proto::Status Reader::scan_for_summary() {
    // No summary: learn what it would have said by reading the whole data section.
    statistics_ = Statistics{};
    ScanVisitor visitor;
    visitor.record = [this](const ScannedRecord& record) -> proto::Result<bool> {
        switch (static_cast<format::Opcode>(record.opcode)) {
            case format::Opcode::schema: {
                auto schema = parse_schema(record.content, record.where());
                if (!schema)
                    return schema.error();
                if (schema->id != 0)
                    schemas_[schema->id] = std::move(*schema);
                break;
            }
            case format::Opcode::channel: {
                auto channel = parse_channel(record.content, record.where());
                if (!channel)
                    return channel.error();
                channels_[channel->id] = std::move(*channel);
                break;
            }
            case format::Opcode::message: {
                auto message = parse_message(record.content, record.where());
                if (!message)
                    return message.error();
                if (statistics_.message_count == 0 || message->log_time < statistics_.message_start_time)
                    statistics_.message_start_time = message->log_time;
                if (statistics_.message_count == 0 || message->log_time > statistics_.message_end_time)
                    statistics_.message_end_time = message->log_time;
                ++statistics_.message_count;
                ++statistics_.channel_message_counts[message->channel_id];
                break;
            }
            case format::Opcode::chunk:
                ++statistics_.chunk_count;
                break;
            case format::Opcode::metadata: {
                auto metadata = parse_metadata(record.content, record.where());
                if (!metadata)
                    return metadata.error();
                metadata_.push_back(std::move(*metadata));
                break;
            }
            case format::Opcode::attachment:
                ++statistics_.attachment_count;
                break;
            default:
                break;
        }
        return true;
    };
    if (auto status = scan_data_section(*source_, data_begin_, data_end_, visitor); !status)
        return status;
    statistics_.schema_count = static_cast<std::uint16_t>(std::min<std::size_t>(schemas_.size(), 0xFFFF));
    statistics_.channel_count = static_cast<std::uint32_t>(channels_.size());
    statistics_.metadata_count = static_cast<std::uint32_t>(metadata_.size());
    return proto::Ok{};
}

proto::Status Reader::for_each_message(const std::function<bool(const MessageView&)>& visit,
                                       const std::set<std::uint16_t>* channels) const {
    ScanVisitor visitor;
    visitor.record = [&](const ScannedRecord& record) -> proto::Result<bool> {
        if (record.opcode != opcode_of(format::Opcode::message))
            return true;
        auto message = parse_message(record.content, record.where());
        if (!message)
            return message.error();
        if (channels != nullptr && channels->count(message->channel_id) == 0)
            return true;
        return visit(*message);
    };
    if (channels != nullptr) {
        // A chunk whose message indexes name none of the wanted channels is not read at all.
        visitor.want_chunk = [&](std::uint64_t offset) {
            const auto found = chunk_channels_.find(offset);
            if (found == chunk_channels_.end() || found->second.empty())
                return true;
            return std::any_of(found->second.begin(), found->second.end(),
                               [&](std::uint16_t channel) { return channels->count(channel) != 0; });
        };
    }
    return scan_data_section(*source_, data_begin_, data_end_, visitor);
}

}  // namespace plexus::mcap
