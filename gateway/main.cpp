// asi-gateway entry point. The service itself lands with issue 3; until then this only wires the
// devices layer (see README "How it fits together").
#include <cstdio>

int main() {
    std::puts("asi-gateway: service not built yet (skeleton)");
    return 1;
}
