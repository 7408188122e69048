// libFuzzer target: the glTF (JSON) loader with an external buffer. The input is the JSON, then
// optionally "\n#BIN\n" and the bytes of input.bin, which the JSON can name as a buffer URI.
#include "fuzz_common.h"
#include "scenes/load.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace raypack;
    const auto [json, bin] = fuzz::splitAt({reinterpret_cast<const char*>(data), size}, "\n#BIN\n");
    fuzz::writeScratch("input.bin", bin);
    const auto path = fuzz::writeScratch("input.gltf", json);
    fuzz::expectCleanOutcome([&] { loadScene(path); });
    return 0;
}
