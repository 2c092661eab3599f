#include "metrics.hpp"

#include <map>
#include <set>
#include <vector>

namespace plexus::daemon::web {

namespace {

using Labels = std::vector<std::pair<std::string, std::string>>;

/// Fields that are levels, not counts: they go up and down.
const std::set<std::string> gauges{"capacity",
                                   "depth",
                                   "bytes",
                                   "queued",
                                   "sessions",
                                   "shm_bytes",
                                   "shm_regions",
                                   "shm_slots",
                                   "memory_bytes",
                                   "quarantined",
                                   "monitors_inline",
                                   "udp_reassembly_bytes",
                                   "connections_open",
                                   "stream_clients",
                                   "calls_outstanding",
                                   "served"};

std::string escaped(const std::string& value) {
    std::string out;
    for (const char c : value) {
        if (c == '\\')
            out += "\\\\";
        else if (c == '"')
            out += "\\\"";
        else if (c == '\n')
            out += "\\n";
        else
            out += c;
    }
    return out;
}

std::string label_text(const Labels& labels, const std::string& extra = {}) {
    std::string text;
    for (const auto& [name, value] : labels)
        text += (text.empty() ? "" : ",") + name + "=\"" + escaped(value) + "\"";
    if (!extra.empty())
        text += (text.empty() ? "" : ",") + extra;
    return text.empty() ? text : "{" + text + "}";
}

std::string number_text(const nlohmann::json& value) {
    if (value.is_boolean())
        return value.get<bool>() ? "1" : "0";
    if (value.is_number_integer() || value.is_number_unsigned())
        return value.dump();
    const double x = value.get<double>();
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.17g", x);
    return buffer;
}

/// A bucket's bound as people write it ("1e-06", "0.00025"): the bounds are round numbers.
std::string bound_text(double bound) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%g", bound);
    return buffer;
}

/// Samples grouped by metric name: the format wants each family's samples together, under one
/// TYPE line.
class Families {
public:
    void add(const std::string& name, const char* type, std::string sample) {
        auto& family = families_[name];
        family.type = type;
        family.samples.push_back(std::move(sample));
    }

    /// Every number (and bool) field of `object` as a metric `prefix_field[_total]`, except those
    /// in `skip` and the nested objects, which the caller walks.
    void numbers(const std::string& prefix, const nlohmann::json& object, const Labels& labels,
                 const std::set<std::string>& skip = {}) {
        for (const auto& [field, value] : object.items()) {
            if (skip.contains(field) || !(value.is_number() || value.is_boolean()))
                continue;
            const bool gauge = gauges.contains(field) || value.is_boolean();
            const std::string name = prefix + "_" + field + (gauge ? "" : "_total");
            add(name, gauge ? "gauge" : "counter", name + label_text(labels) + " " + number_text(value));
        }
    }

    /// A histogram document of LatencyHistogram::to_json as `name` (buckets made cumulative).
    void histogram(const std::string& name, const nlohmann::json& histogram, const Labels& labels) {
        const auto& bounds = histogram.at("le");
        const auto& counts = histogram.at("counts");
        std::uint64_t cumulative = 0;
        for (std::size_t i = 0; i < counts.size(); ++i) {
            cumulative += counts[i].get<std::uint64_t>();
            const std::string le = i < bounds.size() ? bound_text(bounds[i].get<double>()) : "+Inf";
            add(name, "histogram",
                name + "_bucket" + label_text(labels, "le=\"" + le + "\"") + " " +
                    std::to_string(cumulative));
        }
        add(name, "histogram", name + "_sum" + label_text(labels) + " " + number_text(histogram.at("sum")));
        add(name, "histogram", name + "_count" + label_text(labels) + " " + std::to_string(cumulative));
    }

    /// A connection's monitors and what they cost.
    void monitors(const nlohmann::json& entry, Labels labels) {
        if (const auto cost = entry.find("monitor_cost_seconds"); cost != entry.end())
            histogram("plexus_monitor_cost_seconds", *cost, labels);
        const auto monitors = entry.find("monitors");
        if (monitors == entry.end() || !monitors->is_array())
            return;
        for (const auto& monitor : *monitors) {
            Labels own = labels;
            own.emplace_back("side", monitor.value("side", ""));
            own.emplace_back("script", monitor.value("script", ""));
            own.emplace_back("type", monitor.value("type", ""));
            numbers("plexus_monitor", monitor, own);
        }
    }

    std::string text() const {
        std::string out;
        for (const auto& [name, family] : families_) {
            out += "# TYPE " + name + " " + family.type + "\n";
            for (const auto& sample : family.samples)
                out += sample + "\n";
        }
        return out;
    }

private:
    struct Family {
        std::string type;
        std::vector<std::string> samples;
    };
    std::map<std::string, Family> families_;
};

}  // namespace

std::string metrics_text(const nlohmann::json& stats, const HttpCounters& http) {
    Families families;
    const std::string node = stats.value("node", "");
    const Labels daemon_labels{{"node", node}};
    if (const auto daemon = stats.find("daemon"); daemon != stats.end())
        families.numbers("plexus_daemon", *daemon, daemon_labels);
    for (const auto& port : stats.value("ports", nlohmann::json::array())) {
        const std::string name = port.value("name", "");
        const Labels port_labels{{"node", node}, {"port", name}};
        families.numbers("plexus_port", port, port_labels);
        for (const auto& out : port.value("outgoing", nlohmann::json::array())) {
            Labels labels = port_labels;
            labels.emplace_back("destination", out.value("destination", ""));
            families.numbers("plexus_outgoing", out, labels);
            for (const char* carrier : {"udp", "mcast"}) {
                if (const auto part = out.find(carrier); part != out.end() && part->is_object())
                    families.numbers(std::string("plexus_outgoing_") + carrier, *part, labels);
            }
            families.monitors(out, labels);
        }
        for (const auto& in : port.value("inbound", nlohmann::json::array())) {
            Labels labels = port_labels;
            labels.emplace_back("source", in.value("source", ""));
            families.numbers("plexus_inbound", in, labels);
            families.monitors(in, labels);
        }
    }
    const nlohmann::json own = http.to_json();
    families.numbers("plexus_http", own, daemon_labels);
    for (const auto& [reason, count] : own.at("refused").items()) {
        Labels labels = daemon_labels;
        labels.emplace_back("reason", reason);
        families.add("plexus_http_refused_total", "counter",
                     "plexus_http_refused_total" + label_text(labels) + " " + number_text(count));
    }
    return families.text();
}

}  // namespace plexus::daemon::web
