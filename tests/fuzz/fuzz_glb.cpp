// libFuzzer target: the binary glTF (GLB) loader on arbitrary bytes.
#include "fuzz_common.h"
#include "scenes/load.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace raypack;
    const auto path = fuzz::writeScratch("input.glb", {reinterpret_cast<const char*>(data), size});
    fuzz::expectCleanOutcome([&] { loadScene(path); });
    return 0;
}
