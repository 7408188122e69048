#pragma once
// Progress and cancellation of long work on a worker thread: reading and parsing a scene file
// (scenes/load.h) and building a BVH (renderer/bvh.h). One type for both, in the library's core,
// so that renderer/async_build.h, which runs both, needs nothing from scenes/ (scenes/ links
// renderer/, not the other way round).
#include "renderer/error.h"

#include <atomic>
#include <cstdint>

namespace raypack {

// Shared between the thread doing the work and one watching it (a progress bar, a cancel button).
// `total` is set by the work once it knows its size and `done` grows to it, in the work's units:
//  - loading a scene: bytes of work, each byte of the file counted once when read and once when
//    parsed, so total = 2 * file size;
//  - building a BVH: primitives placed in leaves, total = the primitive count.
// Setting `cancel` makes the work throw at its next check (LoadCancelled, BuildCancelled).
struct Progress {
    std::atomic<uint64_t> done{0};
    std::atomic<uint64_t> total{0};
    std::atomic<bool> cancel{false};
};

// The names the loaders and the builders use for it.
using LoadProgress = Progress;
using BuildProgress = Progress;

// Thrown by a loader when Progress::cancel was set. It is a raypack::Error, so code that only shows
// errors still does the right thing; a viewer that wants to stay quiet about a cancel catches it
// first.
class LoadCancelled : public Error {
public:
    using Error::Error;
};

// Thrown by buildBvh when Progress::cancel was set (not an Error: a superseded build is no failure
// to report).
struct BuildCancelled {};

}  // namespace raypack
