// Linked into every test program of a ThreadSanitizer build (RAYPACK_TSAN=ON, tests/CMakeLists.txt):
// limits TBB to one thread before any test runs. Debian's libtbb is not instrumented, so TSan cannot
// see TBB's own synchronisation and reports every hand-off between TBB workers as a race (and the
// instrumented runs outlast ctest's timeouts). With one TBB thread what TSan checks is raypack's
// own threads: the viewer's worker (AsyncSceneBuilder) against the render thread, cancellation
// flags, progress counters.
#include <oneapi/tbb/global_control.h>

namespace {
const tbb::global_control kOneTbbThread(tbb::global_control::max_allowed_parallelism, 1);
}  // namespace
