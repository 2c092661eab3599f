#include "dds_link.hpp"

#include <cstring>
#include <stdexcept>

#include <dds/dds.h>

#include "sensor_msgs/msg/Image.h"

namespace plexus::bench::bridges {

namespace {

void check(dds_return_t code, const char* what) {
    if (code < 0)
        throw std::runtime_error(std::string(what) + ": " + dds_strretcode(-code));
}

class DdsLink final : public Link {
public:
    DdsLink(const std::string& out, const std::string& in, bool keep_all) {
        participant_ = dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr);
        check(participant_, "participant");
        dds_qos_t* qos = dds_create_qos();
        dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
        if (keep_all)
            dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
        else
            dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
        const dds_entity_t out_topic = dds_create_topic(participant_, &sensor_msgs_msg_dds__Image__desc,
                                                        ("rt" + out).c_str(), nullptr, nullptr);
        check(out_topic, "topic");
        const dds_entity_t in_topic = dds_create_topic(participant_, &sensor_msgs_msg_dds__Image__desc,
                                                       ("rt" + in).c_str(), nullptr, nullptr);
        check(in_topic, "topic");
        writer_ = dds_create_writer(participant_, out_topic, qos, nullptr);
        check(writer_, "writer");
        reader_ = dds_create_reader(participant_, in_topic, qos, nullptr);
        check(reader_, "reader");
        dds_delete_qos(qos);
        waitset_ = dds_create_waitset(participant_);
        const dds_entity_t readable = dds_create_readcondition(reader_, DDS_ANY_STATE);
        dds_waitset_attach(waitset_, readable, 0);
    }
    ~DdsLink() override { dds_delete(participant_); }

    void publish(std::span<const std::uint8_t> payload) override {
        sensor_msgs_msg_dds__Image_ image{};
        image.header.frame_id = const_cast<char*>("bench");
        image.encoding = const_cast<char*>("mono8");
        image.width = static_cast<std::uint32_t>(payload.size());
        image.height = 1;
        image.step = image.width;
        image.data._buffer = const_cast<std::uint8_t*>(payload.data());
        image.data._length = image.data._maximum = static_cast<std::uint32_t>(payload.size());
        check(dds_write(writer_, &image), "write");
    }

    std::optional<std::vector<std::uint8_t>> receive(std::chrono::milliseconds timeout) override {
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        for (;;) {
            void* samples[1] = {nullptr};
            dds_sample_info_t info;
            const dds_return_t taken = dds_take(reader_, samples, &info, 1, 1);
            check(taken, "take");
            if (taken == 1) {
                std::optional<std::vector<std::uint8_t>> out;
                if (info.valid_data) {
                    const auto* image = static_cast<const sensor_msgs_msg_dds__Image_*>(samples[0]);
                    out.emplace(image->data._buffer, image->data._buffer + image->data._length);
                }
                dds_return_loan(reader_, samples, 1);
                if (out)
                    return out;
                continue;
            }
            const auto left = deadline - std::chrono::steady_clock::now();
            if (left <= std::chrono::steady_clock::duration::zero())
                return std::nullopt;
            dds_waitset_wait(waitset_, nullptr, 0,
                             std::chrono::duration_cast<std::chrono::nanoseconds>(left).count());
        }
    }

    bool ready() override {
        dds_publication_matched_status_t published;
        dds_subscription_matched_status_t subscribed;
        check(dds_get_publication_matched_status(writer_, &published), "matched");
        check(dds_get_subscription_matched_status(reader_, &subscribed), "matched");
        return published.current_count > 0 && subscribed.current_count > 0;
    }

private:
    dds_entity_t participant_ = 0;
    dds_entity_t writer_ = 0;
    dds_entity_t reader_ = 0;
    dds_entity_t waitset_ = 0;
};

}  // namespace

std::unique_ptr<Link> make_dds_link(const std::string& out, const std::string& in, bool keep_all) {
    return std::make_unique<DdsLink>(out, in, keep_all);
}

}  // namespace plexus::bench::bridges
