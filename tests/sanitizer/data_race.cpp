// Two threads write one int without a lock: ThreadSanitizer must report it ("data race").
#include <cstdio>
#include <thread>

int shared_counter = 0;

int main() {
    std::thread other([] {
        for (int i = 0; i < 100000; ++i)
            ++shared_counter;
    });
    for (int i = 0; i < 100000; ++i)
        ++shared_counter;
    other.join();
    std::printf("%d\n", shared_counter);
    return 0;
}
