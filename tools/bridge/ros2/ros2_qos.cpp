#include "ros2_qos.hpp"

#include <cctype>

#include "mapping.hpp"

namespace plexus::bridge::ros2 {

Qos parse_qos(const std::string& text, Qos defaults, const std::string& where) {
    Qos qos = defaults;
    std::size_t start = 0;
    while (start <= text.size()) {
        const auto comma = text.find(',', start);
        const std::string item =
            text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        if (item == "reliable") {
            qos.reliable = true;
        } else if (item == "best-effort") {
            qos.reliable = false;
        } else if (item == "volatile") {
            qos.transient_local = false;
        } else if (item == "transient-local") {
            qos.transient_local = true;
        } else if (item.rfind("depth=", 0) == 0) {
            const std::string number = item.substr(6);
            if (number.empty() || number.size() > 6 ||
                number.find_first_not_of("0123456789") != std::string::npos || std::stoi(number) < 1)
                throw UsageError(where + ": depth must be a whole number from 1 to 999999, not '" + number +
                                 "'");
            qos.depth = std::stoi(number);
        } else {
            throw UsageError(where + ": unknown QoS '" + item +
                             "' (reliable, best-effort, volatile, transient-local, depth=N)");
        }
        if (comma == std::string::npos)
            break;
        start = comma + 1;
    }
    return qos;
}

namespace {
QosPtr qos_of(const Qos& qos) {
    QosPtr out(dds_create_qos());
    dds_qset_reliability(out.get(), qos.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                         DDS_SECS(1));
    dds_qset_durability(out.get(),
                        qos.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    dds_qset_history(out.get(), DDS_HISTORY_KEEP_LAST, qos.depth);
    return out;
}
}  // namespace

QosPtr reader_qos(const Qos& qos) {
    auto out = qos_of(qos);
    dds_qset_ignorelocal(out.get(), DDS_IGNORELOCAL_PARTICIPANT);
    return out;
}

QosPtr writer_qos(const Qos& qos) {
    return qos_of(qos);
}

std::string dds_topic_name(const std::string& ros_topic, const std::string& where) {
    std::string name = ros_topic;
    if (name.empty() || name.front() != '/')
        name.insert(name.begin(), '/');
    bool ok = name.size() > 1 && name.back() != '/' && name.find("//") == std::string::npos;
    for (std::size_t i = 1; i < name.size(); ++i) {
        const char c = name[i];
        ok = ok && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/');
        if (c != '/' && name[i - 1] == '/')
            ok = ok && !std::isdigit(static_cast<unsigned char>(c));
    }
    if (!ok)
        throw UsageError(where + ": '" + ros_topic +
                         "' is not a ROS 2 topic name (letters, digits and '_' in '/'-separated parts, none "
                         "starting with a digit)");
    return "rt" + name;
}

}  // namespace plexus::bridge::ros2
