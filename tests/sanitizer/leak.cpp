// Loses the only pointer to a heap block: LeakSanitizer must report it at exit ("detected memory leaks").
#include <cstdio>
#include <cstdlib>

int main() {
    void* lost = std::malloc(1000);
    std::printf("%p\n", lost);
    lost = nullptr;
    return 0;
}
