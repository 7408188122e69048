// libFuzzer target: the PLY loader (ascii and binary) on arbitrary bytes.
#include "fuzz_common.h"
#include "scenes/load.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace raypack;
    const auto path = fuzz::writeScratch("input.ply", {reinterpret_cast<const char*>(data), size});
    fuzz::expectCleanOutcome([&] { loadScene(path); });
    return 0;
}
