// libFuzzer target: the PNG reader behind `raypack-cli diff` on arbitrary bytes.
#include "fuzz_common.h"
#include "renderer/image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace raypack;
    const auto path = fuzz::writeScratch("input.png", {reinterpret_cast<const char*>(data), size});
    fuzz::expectCleanOutcome([&] { readPng(path.string()); });
    return 0;
}
