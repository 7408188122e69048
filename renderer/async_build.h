#pragma once
// Loading scenes and building BVHs on a worker thread, for the viewer: the render thread asks,
// keeps rendering what it has, and once per frame takes whatever finished as a value and swaps it
// in at the frame boundary. It never waits on a build (see ../shared/STYLE.md, "Builders are
// functions ... the viewer's worker thread hands back a finished value").
//
// Requests replace one another: there is at most one running job and one waiting request. A new
// request cancels the running job (through BuildProgress::cancel, so buildBvh throws
// BuildCancelled soon after) and takes the waiting slot, so rapid slider changes end in the tree
// of the last request, and nothing in between is handed back once it is superseded.
#include "renderer/bvh.h"
#include "renderer/gpu_bvh.h"
#include "renderer/progress.h"
#include "renderer/scene.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace raypack {

// The renderer library does not call the loaders (scenes/ links renderer/), so the caller passes
// the function that opens a scene spec (a file path or a generator spec, scenes/load.h openScene).
// It reports through LoadProgress, throws raypack::Error for a bad file and LoadCancelled once
// LoadProgress::cancel is set.
using SceneLoader = std::function<Scene(const std::string& spec, LoadProgress& progress)>;

// A finished job: the scene and the tree built over it, ready to be uploaded and traced. A device
// build hands back the tree in device buffers (deviceTree, for GpuTracer::adopt) and the host tree
// only where the request asked for it (bvh null otherwise); a CPU build hands back bvh.
struct SceneBuild {
    uint64_t requestId = 0;
    std::shared_ptr<const Scene> scene;
    std::shared_ptr<const Bvh> bvh;
    std::unique_ptr<GpuTree> deviceTree;
    BvhStats stats;             // of the tree (bvh's, or the device's statistics)
    BvhBuildOptions options;    // it was built with
    std::string scenePath;      // the file it came from (empty for a rebuild of a scene in memory)
    double loadSeconds = 0.0;   // 0 when the scene was not read in this job
    double buildSeconds = 0.0;  // wall clock of buildBvh
};

// A job that stopped with an error (a bad file, a scene too large); the current scene stays.
struct BuildFailure {
    uint64_t requestId = 0;
    std::string scenePath;
    std::string message;
};

enum class BuildPhase { Idle, Loading, Building };

// A snapshot for the progress bar.
struct BuildStatus {
    BuildPhase phase = BuildPhase::Idle;
    uint64_t requestId = 0;
    std::string scenePath;
    double loadFraction = 0.0;    // of the file read and parsed (Loading)
    uint64_t placed = 0;          // primitives placed in leaves (Building)
    uint64_t total = 0;           // primitives in the scene (Building)
    double elapsedSeconds = 0.0;  // since the job started
    bool requestWaiting = false;  // a newer request waits for the running job to stop
};

const char* toString(BuildPhase phase);

// Where the worker runs a device build (gpu-lbvh, gpu-ploc).
enum class DeviceBuilds {
    // On the given context, into a GpuTree the tracer on that context adopts: no host round trip.
    // The build's submissions share the context's queue with the frames, which wait behind them.
    SharedDevice,
    // On a Vulkan device of the worker's own over the same physical device, the tree read back
    // (buildBvhOnDevice) and handed over as a host tree: the frames never wait for the build's
    // submissions. For CPU devices (lavapipe), whose one queue runs a submission at a time on the
    // CPU: there a frame behind a gpu-ploc batch of a 1M-triangle scene waited about a second.
    OwnDevice,
};

class AsyncSceneBuilder {
public:
    // `device`: the context of the tracer that will trace the trees, on which the worker builds with
    // a device builder (gpu-lbvh, gpu-ploc) through a GpuBvhBuilder of its own, into buffers the
    // tracer adopts (no host round trip); the worker and the render thread share its queue through
    // vk::lockQueue. It must outlive this object. Null: device builders fail with an error.
    explicit AsyncSceneBuilder(SceneLoader loader, const vk::VulkanContext* device = nullptr,
                               DeviceBuilds deviceBuilds = DeviceBuilds::SharedDevice);
    // Cancels the running job, drops the waiting one and joins the worker.
    ~AsyncSceneBuilder();
    AsyncSceneBuilder(const AsyncSceneBuilder&) = delete;
    AsyncSceneBuilder& operator=(const AsyncSceneBuilder&) = delete;

    // Read `path` and build over it. Returns the request's id. A device build hands back the host
    // tree too (the start view needs it).
    uint64_t requestLoad(const std::string& path, const BvhBuildOptions& options);
    // Build over `scene` with new options. When a load is still outstanding (waiting, running, or
    // finished but not yet taken), the rebuild applies to that newer scene instead, so a slider
    // moved while a file loads does not bring the old scene back. `scene` may be null before the
    // first scene arrives; with no load outstanding either, nothing is requested and 0 returned.
    // `hostTree`: a device build also reads the tree back (for a CPU tracer); without it the
    // caller reads it back when a CPU consumer asks (GpuTracer::downloadBvh).
    uint64_t requestRebuild(std::shared_ptr<const Scene> scene, const BvhBuildOptions& options, bool hostTree = true);

    // Non-blocking; called by the render thread once per frame. The newest finished build that no
    // later request has superseded, if any, and the newest failure, if any.
    std::optional<SceneBuild> takeFinished();
    std::optional<BuildFailure> takeFailure();

    // Frees `tree` on the worker thread (between jobs): a tracer's replaced tree
    // (GpuTracer::setRetiredTreeSink), so that the render thread does not wait for it.
    void retire(std::unique_ptr<GpuTree> tree);

    BuildStatus status() const;
    // Blocks until idle. For scripted runs and tests only: the render loop never calls it.
    void waitIdle();

private:
    struct Request {
        uint64_t id = 0;
        std::string path;                    // non-empty: read this file first
        std::shared_ptr<const Scene> scene;  // otherwise build over this scene
        BvhBuildOptions options;
        bool reuseLoaded = false;  // a path repeated by a rebuild may reuse the scene just read
        bool hostTree = true;      // a device build reads the tree back too
    };
    struct RunningJob {
        uint64_t id = 0;
        std::string path;
        BuildPhase phase = BuildPhase::Idle;
        std::chrono::steady_clock::time_point start;
        LoadProgress loadProgress;
        BuildProgress buildProgress;
    };

    void workerLoop();
    void run(const Request& request, RunningJob& job);
    void cancelRunningLocked();

    SceneLoader loader_;
    const vk::VulkanContext* device_ = nullptr;
    DeviceBuilds deviceBuilds_ = DeviceBuilds::SharedDevice;
    // DeviceBuilds::OwnDevice: the worker's context on device_'s physical device, made on first use.
    std::unique_ptr<vk::VulkanContext> ownDevice_;
    // The worker's device builder (made on its first device build) and the scene it holds, kept
    // alive so that no later scene can take its address while the builder still keeps its arrays.
    std::unique_ptr<GpuBvhBuilder> deviceBuilder_;
    std::shared_ptr<const Scene> deviceScene_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;    // a request arrived, or shutdown
    std::condition_variable idleCv_;  // a job ended
    std::optional<Request> waiting_;
    std::shared_ptr<RunningJob> running_;
    std::optional<SceneBuild> finished_;
    std::optional<BuildFailure> failure_;
    std::vector<std::unique_ptr<GpuTree>> retired_;
    // The path of the latest load request until its scene is taken by the render thread.
    std::string outstandingLoadPath_;
    // The last scene read, so that a rebuild that arrives during a load does not read it again.
    std::string lastLoadedPath_;
    std::shared_ptr<const Scene> lastLoadedScene_;
    uint64_t nextId_ = 1;
    bool shutdown_ = false;
    std::thread worker_;  // last: started once everything above is initialised
};

}  // namespace raypack
