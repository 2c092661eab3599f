// The certainty monitor of configs/monitors/certainty.lua, compiled: drops detections whose
// `certainty` is below a threshold and, with `event.NAME`, raises NAME in the input port's event
// container while detections reach it. Same options, same behaviour, same parameters:
//   tcp+recv.portmonitor+type.so+file.certainty+threshold.0.7+event.e_template_ok+lifetime.0.5
// (plexusd --monitor-libs DIR, with certainty.so in DIR). Options: threshold (default 0.5),
// event, lifetime (seconds), keep (a flag: raise the event but pass every detection on).
//
// Numbers are read as Lua's tonumber reads decimal ones ("0.8", " 1e-1 ", "1"); like tonumber it
// refuses "inf" and "nan". Unlike it, hexadecimal integers ("0x10") become floats here.
#include <plexus/monitor_plugin.h>

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <new>
#include <optional>
#include <string>

namespace {

/// A Lua number: getparam gives an integer back as an integer, as the script does.
struct Number {
    double value = 0.5;
    bool integer = false;
    std::int64_t whole = 0;
};

std::optional<Number> to_number(std::string text) {
    while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
        text.pop_back();
    std::size_t start = 0;
    while (start < text.size() && std::isspace(static_cast<unsigned char>(text[start])))
        ++start;
    text.erase(0, start);
    if (text.empty() || text.find_first_of("iInN") != std::string::npos)
        return std::nullopt;
    Number number;
    char* end = nullptr;
    errno = 0;
    const long long whole = std::strtoll(text.c_str(), &end, 10);
    if (errno == 0 && *end == '\0') {
        number.integer = true;
        number.whole = whole;
        number.value = static_cast<double>(whole);
        return number;
    }
    number.value = std::strtod(text.c_str(), &end);
    if (*end != '\0')
        return std::nullopt;
    return number;
}

struct Certainty {
    plexus_host* host = nullptr;
    const plexus_host_api* api = nullptr;
    Number threshold;
    std::optional<std::string> event;
    std::optional<Number> lifetime;
    bool keep = false;

    /// A host function failed: its reason becomes this callback's error.
    int fail() {
        api->set_error(host, api->last_error(host));
        return PLEXUS_MONITOR_ERROR;
    }
    int refuse(const std::string& why) {
        api->log(host, PLEXUS_LOG_INFO, why.c_str());  // where the script's print goes
        api->set_error(host, why.c_str());
        return PLEXUS_MONITOR_REFUSE;
    }
};

/// The value of option `key`, or null.
const char* option(const plexus_option* options, std::size_t count, const char* key) {
    for (std::size_t i = 0; i < count; ++i) {
        if (std::strcmp(options[i].key, key) == 0)
            return options[i].value;
    }
    return nullptr;
}

int create(plexus_host* host, const plexus_host_api* api, const plexus_option* options, std::size_t count,
           void** state) {
    auto* self = new (std::nothrow) Certainty;
    if (!self)
        return PLEXUS_MONITOR_ERROR;
    self->host = host;
    self->api = api;
    // In the script's order, so that the same bad option is reported first.
    if (const char* threshold = option(options, count, "threshold")) {
        auto number = to_number(threshold);
        if (!number) {
            const int refused = self->refuse(std::string("threshold must be a number, got ") + threshold);
            delete self;
            return refused;
        }
        self->threshold = *number;
    }
    if (const char* event = option(options, count, "event"))
        self->event = event;
    if (const char* lifetime = option(options, count, "lifetime")) {
        self->lifetime = to_number(lifetime);
        if (!self->lifetime) {
            const int refused =
                self->refuse(std::string("lifetime must be a number of seconds, got ") + lifetime);
            delete self;
            return refused;
        }
    }
    self->keep = option(options, count, "keep") != nullptr;
    *state = self;
    return PLEXUS_MONITOR_OK;
}

/// A map whose `certainty` is a number at least the threshold.
bool good(const Certainty& self, plexus_value data) {
    // map_get of anything but a map is absent, and get_number of absent fails: no type() needed.
    double certainty = 0;
    return self.api->get_number(self.api->map_get(data, "certainty"), &certainty) == PLEXUS_MONITOR_OK &&
           certainty >= self.threshold.value;
}

int accept(void* state, const plexus_message* message) {
    auto& self = *static_cast<Certainty*>(state);
    const bool is_good = good(self, message->data);
    if (self.event) {
        const double* lifetime = self.lifetime ? &self.lifetime->value : nullptr;
        const int status = is_good ? self.api->set_event(self.host, self.event->c_str(), lifetime)
                                   : self.api->unset_event(self.host, self.event->c_str());
        if (status != PLEXUS_MONITOR_OK)
            return self.fail();
    }
    return is_good || self.keep ? PLEXUS_MONITOR_PASS : PLEXUS_MONITOR_DROP;
}

void put_number(const plexus_host_api& api, plexus_builder* out, const Number& number) {
    if (number.integer)
        api.put_int(out, number.whole);
    else
        api.put_float(out, number.value);
}

int getparam(void* state, plexus_builder* out) {
    const auto& self = *static_cast<Certainty*>(state);
    const plexus_host_api& api = *self.api;
    api.begin_map(out, 1 + (self.event ? 1 : 0) + (self.lifetime ? 1 : 0));
    api.put_string(out, "threshold", 9);
    put_number(api, out, self.threshold);
    if (self.event) {
        api.put_string(out, "event", 5);
        api.put_string(out, self.event->data(), self.event->size());
    }
    if (self.lifetime) {
        api.put_string(out, "lifetime", 8);
        put_number(api, out, *self.lifetime);
    }
    return PLEXUS_MONITOR_OK;
}

int setparam(void* state, plexus_value values) {
    auto& self = *static_cast<Certainty*>(state);
    const plexus_host_api& api = *self.api;
    const plexus_value threshold = api.map_get(values, "threshold");
    std::int64_t whole = 0;
    double real = 0;
    const char* text = nullptr;
    std::size_t size = 0;
    if (api.get_int(threshold, &whole) == PLEXUS_MONITOR_OK) {
        self.threshold = Number{static_cast<double>(whole), true, whole};
    } else if (api.get_number(threshold, &real) == PLEXUS_MONITOR_OK) {
        self.threshold = Number{real, false, 0};
    } else if (api.get_string(threshold, &text, &size) == PLEXUS_MONITOR_OK) {
        if (auto number = to_number(std::string(text, size)))  // else keep the old one, as the script
            self.threshold = *number;
    }
    return PLEXUS_MONITOR_OK;
}

void destroy(void* state) {
    delete static_cast<Certainty*>(state);
}

const plexus_monitor_plugin descriptor = {
    PLEXUS_MONITOR_ABI_VERSION,
    "certainty",
    create,
    accept,
    nullptr,  // no update: detections pass unchanged
    nullptr,  // no trig
    getparam,
    setparam,
    destroy,
};

}  // namespace

extern "C" PLEXUS_MONITOR_EXPORT const plexus_monitor_plugin* plexus_monitor_entry(void) {
    return &descriptor;
}
