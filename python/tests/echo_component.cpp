// plexus-python-echo: a C++ component for the Python client's tests. Reads /cpp/echo/in and
// writes to /cpp/echo/out, for each message, {"data": what arrived, "type": its type as C++ sees
// it, "size": a blob's byte count or a container's element count}: the test then knows both that
// libplexus in C++ decoded what Python wrote and that Python decodes what C++ wrote.
#include <iostream>

#include <plexus/client.hpp>

int main(int argc, char** argv) {
    const std::string in_name = argc > 1 ? argv[1] : "/cpp/echo/in";
    const std::string out_name = argc > 2 ? argv[2] : "/cpp/echo/out";
    try {
        plexus::Client client;
        auto in = client.open(in_name);
        auto out = client.open(out_name);
        std::cout << "ready" << std::endl;  // the test waits for this line, not for time
        for (;;) {
            auto message = in.read(std::chrono::seconds(1));
            if (!message)
                continue;
            const auto& data = message->data;
            const std::size_t size = data.is_binary() ? data.get_binary().size() : data.size();
            out.write({{"data", data}, {"type", data.type_name()}, {"size", size}});
        }
    } catch (const plexus::Error& e) {
        std::cerr << "plexus-python-echo: " << e.what() << '\n';
        return static_cast<int>(e.code());
    }
}
