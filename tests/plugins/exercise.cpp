// A plugin that uses the rest of the ABI, for the unit tests:
//   create  reads option `port` (where trig publishes) and sets a trig interval of 0.5 s;
//   accept  drops a message whose data is a map with "drop": true, fails (set_error) on "fail": true;
//   update  replaces the payload by {"x": data.x * 2, "seq": seq, "source": source} when data has x;
//   trig    publishes {"trig": count} on the port;
//   getparam/setparam  a map {"count": trigs, "factor": f}; setparam takes "factor".
#include <plexus/monitor_plugin.h>

#include <cstring>
#include <new>
#include <string>

namespace {

struct Exercise {
    plexus_host* host = nullptr;
    const plexus_host_api* api = nullptr;
    std::string port = "/exercise/out";
    std::int64_t trigs = 0;
    double factor = 2;
};

int create(plexus_host* host, const plexus_host_api* api, const plexus_option* options, std::size_t count,
           void** state) {
    auto* self = new (std::nothrow) Exercise{host, api};
    if (!self)
        return PLEXUS_MONITOR_ERROR;
    for (std::size_t i = 0; i < count; ++i) {
        if (std::strcmp(options[i].key, "port") == 0)
            self->port = options[i].value;
    }
    if (api->set_trig_interval(host, 0.5) != PLEXUS_MONITOR_OK) {
        api->set_error(host, api->last_error(host));
        delete self;
        return PLEXUS_MONITOR_ERROR;
    }
    *state = self;
    return PLEXUS_MONITOR_OK;
}

int accept(void* state, const plexus_message* message) {
    auto& self = *static_cast<Exercise*>(state);
    int flag = 0;
    if (self.api->get_bool(self.api->map_get(message->data, "fail"), &flag) == PLEXUS_MONITOR_OK && flag) {
        self.api->set_error(self.host, "asked to fail");
        return PLEXUS_MONITOR_ERROR;
    }
    if (self.api->get_bool(self.api->map_get(message->data, "drop"), &flag) == PLEXUS_MONITOR_OK && flag)
        return PLEXUS_MONITOR_DROP;
    return PLEXUS_MONITOR_PASS;
}

int update(void* state, const plexus_message* message, plexus_builder* out) {
    auto& self = *static_cast<Exercise*>(state);
    const plexus_host_api& api = *self.api;
    double x = 0;
    if (api.get_number(api.map_get(message->data, "x"), &x) != PLEXUS_MONITOR_OK)
        return PLEXUS_MONITOR_OK;  // nothing built: the message passes unchanged
    api.begin_map(out, 3);
    api.put_string(out, "x", 1);
    api.put_float(out, x * self.factor);
    api.put_string(out, "seq", 3);
    api.put_int(out, static_cast<std::int64_t>(message->seq));
    api.put_string(out, "source", 6);
    api.put_string(out, message->source, message->source_size);
    return PLEXUS_MONITOR_OK;
}

int trig(void* state) {
    auto& self = *static_cast<Exercise*>(state);
    const plexus_host_api& api = *self.api;
    ++self.trigs;
    plexus_builder* value = api.builder_new(self.host);
    api.begin_map(value, 1);
    api.put_string(value, "trig", 4);
    api.put_int(value, self.trigs);
    const int published = api.publish(self.host, self.port.c_str(), api.builder_value(value));
    api.builder_free(value);
    if (published != PLEXUS_MONITOR_OK) {
        api.set_error(self.host, api.last_error(self.host));
        return PLEXUS_MONITOR_ERROR;
    }
    return PLEXUS_MONITOR_OK;
}

int getparam(void* state, plexus_builder* out) {
    const auto& self = *static_cast<Exercise*>(state);
    self.api->begin_map(out, 2);
    self.api->put_string(out, "count", 5);
    self.api->put_int(out, self.trigs);
    self.api->put_string(out, "factor", 6);
    self.api->put_float(out, self.factor);
    return PLEXUS_MONITOR_OK;
}

int setparam(void* state, plexus_value values) {
    auto& self = *static_cast<Exercise*>(state);
    double factor = 0;
    if (self.api->get_number(self.api->map_get(values, "factor"), &factor) == PLEXUS_MONITOR_OK)
        self.factor = factor;
    return PLEXUS_MONITOR_OK;
}

void destroy(void* state) {
    delete static_cast<Exercise*>(state);
}

const plexus_monitor_plugin descriptor = {
    PLEXUS_MONITOR_ABI_VERSION, "exercise", create, accept, update, trig, getparam, setparam, destroy};

}  // namespace

extern "C" PLEXUS_MONITOR_EXPORT const plexus_monitor_plugin* plexus_monitor_entry(void) {
    return &descriptor;
}
