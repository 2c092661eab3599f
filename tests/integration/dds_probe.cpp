// plexus-dds-probe: a DDS program of the tests' own, written as a ROS 2 node's DDS traffic looks
// (topic rt/NAME, type pkg::msg::dds_::Name_, reliable volatile keep-last-10) and using the C
// structs directly — not the bridge's converter — so that a conversion mistake of the bridge
// shows against it. Prints one line per sample it reads, flushed.
//
//   plexus-dds-probe pub-string TOPIC TEXT      publishes TEXT every 50 ms (the count in {n})
//   plexus-dds-probe sub-string TOPIC           prints each String's data
//   plexus-dds-probe pub-bool TOPIC true|false  publishes a Bool every 20 ms (a held button)
//   plexus-dds-probe pub-twist TOPIC X          publishes Twist{linear.x = X, angular.z = -X} every 20 ms
//   plexus-dds-probe sub-twist TOPIC            prints "linear.x angular.z" of each Twist
//   plexus-dds-probe pub-image TOPIC BYTES      publishes one Image of BYTES bytes every 500 ms
//   plexus-dds-probe sub-image TOPIC            prints "width height encoding bytes fnv1a" of each Image
// Runs until killed. The domain is $ROS_DOMAIN_ID, else 0.
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <dds/dds.h>

#include "geometry_msgs/msg/Twist.h"
#include "sensor_msgs/msg/Image.h"
#include "std_msgs/msg/Bool.h"
#include "std_msgs/msg/String.h"

namespace {

std::uint64_t fnv1a(const std::uint8_t* data, std::size_t size) {
    std::uint64_t hash = 1469598103934665603ull;
    for (std::size_t i = 0; i < size; ++i) {
        hash ^= data[i];
        hash *= 1099511628211ull;
    }
    return hash;
}

std::uint8_t pattern(std::size_t i) {
    return static_cast<std::uint8_t>((i * 7 + i / 251) & 0xff);
}

dds_qos_t* ros2_qos() {
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
    return qos;
}

int fail(const char* what, dds_return_t code) {
    std::fprintf(stderr, "plexus-dds-probe: %s: %s\n", what, dds_strretcode(-code));
    return 4;
}

template <class Each>
int subscribe(dds_entity_t participant, const dds_topic_descriptor_t* descriptor,
              const std::string& topic_name, Each each) {
    const dds_entity_t topic =
        dds_create_topic(participant, descriptor, topic_name.c_str(), nullptr, nullptr);
    if (topic < 0)
        return fail("topic", topic);
    dds_qos_t* qos = ros2_qos();
    const dds_entity_t reader = dds_create_reader(participant, topic, qos, nullptr);
    dds_delete_qos(qos);
    if (reader < 0)
        return fail("reader", reader);
    const dds_entity_t waitset = dds_create_waitset(participant);
    const dds_entity_t readable = dds_create_readcondition(reader, DDS_ANY_STATE);
    dds_waitset_attach(waitset, readable, 0);
    for (;;) {
        dds_waitset_wait(waitset, nullptr, 0, DDS_SECS(1));
        void* samples[8] = {nullptr};
        dds_sample_info_t infos[8];
        const dds_return_t taken = dds_take(reader, samples, infos, 8, 8);
        for (dds_return_t i = 0; i < taken; ++i) {
            if (infos[i].valid_data)
                each(samples[i]);
        }
        if (taken > 0)
            dds_return_loan(reader, samples, taken);
        std::fflush(stdout);
    }
}

template <class Fill>
int publish(dds_entity_t participant, const dds_topic_descriptor_t* descriptor, const std::string& topic_name,
            std::chrono::milliseconds period, Fill fill) {
    const dds_entity_t topic =
        dds_create_topic(participant, descriptor, topic_name.c_str(), nullptr, nullptr);
    if (topic < 0)
        return fail("topic", topic);
    dds_qos_t* qos = ros2_qos();
    const dds_entity_t writer = dds_create_writer(participant, topic, qos, nullptr);
    dds_delete_qos(qos);
    if (writer < 0)
        return fail("writer", writer);
    for (std::uint64_t n = 1;; ++n) {
        const dds_return_t written = fill(writer, n);
        if (written < 0)
            std::fprintf(stderr, "plexus-dds-probe: write: %s\n", dds_strretcode(-written));
        std::this_thread::sleep_for(period);  // a publisher's own rate, as a ROS 2 node's timer
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(
            stderr,
            "usage: plexus-dds-probe pub-string|sub-string|pub-bool|pub-twist|sub-twist|pub-image|sub-image "
            "TOPIC [ARG]\n");
        return 2;
    }
    const std::string command = argv[1];
    const std::string topic = std::string("rt") + argv[2];
    const char* argument = argc > 3 ? argv[3] : "";
    const char* domain_text = std::getenv("ROS_DOMAIN_ID");
    const dds_domainid_t domain = domain_text ? static_cast<dds_domainid_t>(std::atoi(domain_text)) : 0;
    const dds_entity_t participant = dds_create_participant(domain, nullptr, nullptr);
    if (participant < 0)
        return fail("participant", participant);

    if (command == "pub-string") {
        return publish(participant, &std_msgs_msg_dds__String__desc, topic, std::chrono::milliseconds(50),
                       [&](dds_entity_t writer, std::uint64_t n) {
                           std::string text = argument;
                           if (const auto at = text.find("{n}"); at != std::string::npos)
                               text.replace(at, 3, std::to_string(n));
                           std_msgs_msg_dds__String_ sample{const_cast<char*>(text.c_str())};
                           return dds_write(writer, &sample);
                       });
    }
    if (command == "sub-string") {
        return subscribe(participant, &std_msgs_msg_dds__String__desc, topic, [](void* sample) {
            std::printf("%s\n", static_cast<std_msgs_msg_dds__String_*>(sample)->data);
        });
    }
    if (command == "pub-bool") {
        const bool value = std::string(argument) == "true";
        return publish(participant, &std_msgs_msg_dds__Bool__desc, topic, std::chrono::milliseconds(20),
                       [&](dds_entity_t writer, std::uint64_t) {
                           std_msgs_msg_dds__Bool_ sample{value};
                           return dds_write(writer, &sample);
                       });
    }
    if (command == "pub-twist") {
        const double x = std::atof(argument);
        return publish(participant, &geometry_msgs_msg_dds__Twist__desc, topic, std::chrono::milliseconds(20),
                       [&](dds_entity_t writer, std::uint64_t) {
                           geometry_msgs_msg_dds__Twist_ sample{};
                           sample.linear.x = x;
                           sample.angular.z = -x;
                           return dds_write(writer, &sample);
                       });
    }
    if (command == "sub-twist") {
        return subscribe(participant, &geometry_msgs_msg_dds__Twist__desc, topic, [](void* sample) {
            const auto* twist = static_cast<geometry_msgs_msg_dds__Twist_*>(sample);
            std::printf("%g %g\n", twist->linear.x, twist->angular.z);
        });
    }
    if (command == "pub-image") {
        const std::size_t bytes = std::strtoull(argument, nullptr, 10);
        std::vector<std::uint8_t> data(bytes);
        for (std::size_t i = 0; i < bytes; ++i)
            data[i] = pattern(i);
        return publish(participant, &sensor_msgs_msg_dds__Image__desc, topic, std::chrono::milliseconds(500),
                       [&](dds_entity_t writer, std::uint64_t) {
                           sensor_msgs_msg_dds__Image_ sample{};
                           sample.header.frame_id = const_cast<char*>("camera");
                           sample.width = static_cast<std::uint32_t>(bytes / 3 / 1000);
                           sample.height = 1000;
                           sample.step = sample.width * 3;
                           sample.encoding = const_cast<char*>("rgb8");
                           sample.data._buffer = data.data();
                           sample.data._length = sample.data._maximum = static_cast<std::uint32_t>(bytes);
                           sample.data._release = false;
                           return dds_write(writer, &sample);
                       });
    }
    if (command == "sub-image") {
        return subscribe(participant, &sensor_msgs_msg_dds__Image__desc, topic, [](void* sample) {
            const auto* image = static_cast<sensor_msgs_msg_dds__Image_*>(sample);
            std::printf("%u %u %s %u %016" PRIx64 "\n", image->width, image->height, image->encoding,
                        image->data._length, fnv1a(image->data._buffer, image->data._length));
        });
    }
    std::fprintf(stderr, "plexus-dds-probe: unknown command %s\n", command.c_str());
    return 2;
}
