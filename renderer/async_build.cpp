#include "renderer/async_build.h"

#include "renderer/bvh_build.h"  // throwIfCancelled
#include "renderer/error.h"
#include "renderer/gpu_bvh.h"
#include "renderer/measure/spread.h"
#include "renderer/vk/context.h"

#include <exception>
#include <vector>

namespace raypack {

const char* toString(BuildPhase phase) {
    switch (phase) {
    case BuildPhase::Idle: return "idle";
    case BuildPhase::Loading: return "loading";
    case BuildPhase::Building: return "building";
    }
    return "?";
}

AsyncSceneBuilder::AsyncSceneBuilder(SceneLoader loader, const vk::VulkanContext* device, DeviceBuilds deviceBuilds)
    : loader_(std::move(loader)), device_(device), deviceBuilds_(deviceBuilds), worker_([this] { workerLoop(); }) {
    RAYPACK_CHECK(loader_);
}

AsyncSceneBuilder::~AsyncSceneBuilder() {
    {
        std::lock_guard lock(mutex_);
        shutdown_ = true;
        waiting_.reset();
        cancelRunningLocked();
    }
    wake_.notify_all();
    worker_.join();
    retired_.clear();
    deviceBuilder_.reset();
    if (ownDevice_) vk::destroyVulkanContext(*ownDevice_);
}

void AsyncSceneBuilder::cancelRunningLocked() {
    if (running_) {
        running_->buildProgress.cancel = true;
        running_->loadProgress.cancel = true;
    }
}

uint64_t AsyncSceneBuilder::requestLoad(const std::string& path, const BvhBuildOptions& options) {
    uint64_t id;
    {
        std::lock_guard lock(mutex_);
        id = nextId_++;
        waiting_ = Request{id, path, nullptr, options, /*reuseLoaded=*/false, /*hostTree=*/true};
        outstandingLoadPath_ = path;
        cancelRunningLocked();
    }
    wake_.notify_all();
    return id;
}

uint64_t AsyncSceneBuilder::requestRebuild(std::shared_ptr<const Scene> scene, const BvhBuildOptions& options,
                                           bool hostTree) {
    uint64_t id;
    {
        std::lock_guard lock(mutex_);
        id = nextId_++;
        if (!outstandingLoadPath_.empty())
            waiting_ = Request{id, outstandingLoadPath_, nullptr, options, /*reuseLoaded=*/true, /*hostTree=*/true};
        else if (scene)
            waiting_ = Request{id, {}, std::move(scene), options, false, hostTree};
        else
            return 0;  // no scene yet and none loading: nothing to build
        cancelRunningLocked();
    }
    wake_.notify_all();
    return id;
}

std::optional<SceneBuild> AsyncSceneBuilder::takeFinished() {
    std::lock_guard lock(mutex_);
    std::optional<SceneBuild> taken = std::move(finished_);
    finished_.reset();
    // Once the render thread holds the newest loaded scene, later rebuilds apply to its copy.
    if (taken && !taken->scenePath.empty() && taken->scenePath == outstandingLoadPath_ && !waiting_ && !running_)
        outstandingLoadPath_.clear();
    return taken;
}

std::optional<BuildFailure> AsyncSceneBuilder::takeFailure() {
    std::lock_guard lock(mutex_);
    std::optional<BuildFailure> taken = std::move(failure_);
    failure_.reset();
    return taken;
}

void AsyncSceneBuilder::retire(std::unique_ptr<GpuTree> tree) {
    {
        std::lock_guard lock(mutex_);
        retired_.push_back(std::move(tree));
    }
    wake_.notify_all();
}

BuildStatus AsyncSceneBuilder::status() const {
    std::lock_guard lock(mutex_);
    BuildStatus status;
    status.requestWaiting = waiting_.has_value();
    if (running_) {
        status.phase = running_->phase;
        status.requestId = running_->id;
        status.scenePath = running_->path;
        const uint64_t loadTotal = running_->loadProgress.total.load();
        status.loadFraction = loadTotal ? double(running_->loadProgress.done.load()) / double(loadTotal) : 0.0;
        status.placed = running_->buildProgress.done.load();
        status.total = running_->buildProgress.total.load();
        status.elapsedSeconds = secondsSince(running_->start);
    }
    return status;
}

void AsyncSceneBuilder::waitIdle() {
    std::unique_lock lock(mutex_);
    idleCv_.wait(lock, [&] { return !running_ && !waiting_; });
}

void AsyncSceneBuilder::workerLoop() {
    std::unique_lock lock(mutex_);
    for (;;) {
        wake_.wait(lock, [&] { return shutdown_ || waiting_.has_value() || !retired_.empty(); });
        if (shutdown_) break;
        if (!retired_.empty()) {
            std::vector<std::unique_ptr<GpuTree>> trees = std::move(retired_);
            retired_.clear();
            lock.unlock();
            trees.clear();
            lock.lock();
            continue;
        }
        const Request request = std::move(*waiting_);
        waiting_.reset();
        auto job = std::make_shared<RunningJob>();
        job->id = request.id;
        job->path = request.path;
        job->phase = request.path.empty() ? BuildPhase::Building : BuildPhase::Loading;
        job->start = std::chrono::steady_clock::now();
        running_ = job;
        lock.unlock();
        run(request, *job);
        lock.lock();
        running_.reset();
        idleCv_.notify_all();
    }
    running_.reset();
    idleCv_.notify_all();
}

void AsyncSceneBuilder::run(const Request& request, RunningJob& job) {
    const bool isLoad = !request.path.empty();
    try {
        std::shared_ptr<const Scene> scene = request.scene;
        double loadSeconds = 0.0;
        if (isLoad) {
            {
                std::lock_guard lock(mutex_);
                if (request.reuseLoaded && lastLoadedPath_ == request.path) scene = lastLoadedScene_;
            }
            if (!scene) {
                const auto loadStart = std::chrono::steady_clock::now();
                scene = std::make_shared<const Scene>(loader_(request.path, job.loadProgress));
                loadSeconds = secondsSince(loadStart);
                std::lock_guard lock(mutex_);
                // Kept even when this job was cancelled: the request that cancelled it is often a
                // rebuild of this very file.
                lastLoadedPath_ = request.path;
                lastLoadedScene_ = scene;
            }
            if (job.loadProgress.cancel) return;
            std::lock_guard lock(mutex_);
            job.phase = BuildPhase::Building;
        }

        const auto buildStart = std::chrono::steady_clock::now();
        SceneBuild build;
        build.options = request.options;
        if (isGpuBvhBuilder(request.options.builder)) {
            if (!device_)
                throw Error(std::string(toString(request.options.builder)) + " builds on a Vulkan device; none given");
            job.buildProgress.total.store(scene->triangleCount());
            bvh_detail::throwIfCancelled(&job.buildProgress);
            if (deviceBuilds_ == DeviceBuilds::OwnDevice) {
                if (!ownDevice_) {
                    vk::VulkanContextOptions options;
                    options.device = std::to_string(device_->info.index);
                    ownDevice_ = std::make_unique<vk::VulkanContext>(vk::createVulkanContext(options));
                }
                build.bvh = std::make_shared<const Bvh>(
                    buildBvhOnDevice(*ownDevice_, *scene, request.options, &job.buildProgress));
                build.stats = build.bvh->stats;
            } else {
                if (!deviceBuilder_) deviceBuilder_ = std::make_unique<GpuBvhBuilder>(*device_);
                deviceScene_ = scene;
                // The order is kept either way: a CPU consumer may ask for the host tree later.
                build.deviceTree =
                    buildGpuTree(*deviceBuilder_, *scene, request.options, /*keepOrder=*/true, &job.buildProgress);
                build.stats = build.deviceTree->stats;
                if (request.hostTree && !job.buildProgress.cancel) {
                    build.bvh = std::make_shared<const Bvh>(downloadGpuTree(*build.deviceTree));
                    build.stats = build.bvh->stats;
                }
                job.buildProgress.done.store(scene->triangleCount());
            }
        } else {
            build.bvh = std::make_shared<const Bvh>(buildBvh(*scene, request.options, &job.buildProgress));
            build.stats = build.bvh->stats;
        }
        build.buildSeconds = secondsSince(buildStart);
        build.requestId = request.id;
        build.scene = std::move(scene);
        build.scenePath = request.path;
        build.loadSeconds = loadSeconds;

        std::lock_guard lock(mutex_);
        if (job.buildProgress.cancel) return;
        finished_ = std::move(build);
    } catch (const BuildCancelled&) {
        // Superseded by a newer request: nothing to hand back.
    } catch (const std::exception& e) {
        std::lock_guard lock(mutex_);
        if (job.buildProgress.cancel || job.loadProgress.cancel) return;
        failure_ = BuildFailure{request.id, request.path, e.what()};
        if (isLoad && request.path == outstandingLoadPath_ && !waiting_)
            outstandingLoadPath_.clear();  // the current scene stays; rebuilds apply to it again
    }
}

}  // namespace raypack
