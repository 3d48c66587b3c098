#include <cstdio>
int main() {
    std::puts("ms2000-sim: not built yet");
    return 1;
}
