// libFuzzer target: the hits file reader (docs/hits-format.md) on arbitrary bytes.
#include "fuzz_common.h"
#include "renderer/hits_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace raypack;
    const auto path = fuzz::writeScratch("input.hits", {reinterpret_cast<const char*>(data), size});
    fuzz::expectCleanOutcome([&] { readHits(path.string()); });
    return 0;
}
