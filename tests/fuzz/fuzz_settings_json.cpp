// libFuzzer target: a `render --from` settings file: reading the JSON and turning it into a setup.
#include "fuzz_common.h"
#include "renderer/settings_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace raypack;
    const auto path = fuzz::writeScratch("input.json", {reinterpret_cast<const char*>(data), size});
    fuzz::expectCleanOutcome([&] { renderSetupFromJson(readJsonFile(path.string())); });
    return 0;
}
