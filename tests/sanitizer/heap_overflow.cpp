// Writes one element past a heap array: AddressSanitizer must stop it ("heap-buffer-overflow").
#include <cstdio>
#include <cstdlib>

int main(int argc, char**) {
    auto* values = static_cast<int*>(std::malloc(4 * sizeof(int)));
    values[4 + argc - 1] = 1;  // index 4: one past the end (argc keeps the compiler from seeing it)
    std::printf("%d\n", values[0]);
    std::free(values);
    return 0;
}
