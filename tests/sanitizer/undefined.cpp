// Signed overflow: UndefinedBehaviorSanitizer must report it ("runtime error").
#include <climits>
#include <cstdio>

int main(int argc, char**) {
    int big = INT_MAX - 1 + argc;  // INT_MAX with no arguments
    big += argc;                   // overflows
    std::printf("%d\n", big);
    return 0;
}
