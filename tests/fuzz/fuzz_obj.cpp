// libFuzzer target: the OBJ loader with an MTL library. The input is the OBJ, then optionally
// "\n#MTL\n" and the bytes of input.mtl, which the OBJ can name with `mtllib input.mtl`.
#include "fuzz_common.h"
#include "scenes/load.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace raypack;
    const auto [obj, mtl] = fuzz::splitAt({reinterpret_cast<const char*>(data), size}, "\n#MTL\n");
    fuzz::writeScratch("input.mtl", mtl);
    const auto path = fuzz::writeScratch("input.obj", obj);
    fuzz::expectCleanOutcome([&] { loadScene(path); });
    return 0;
}
