// Embree 3 as a tracer, "embree": the tracer a CPU user would pick, measured on the same triangles
// and the same rays as raypack (issue 5, "Peers"): the same camera (shaders/camera.h's
// primaryRayDirection), the same light (lightPosition) and the same shadow-ray convention (from the
// light towards the hit point, ignoring intersections at or beyond it). Built only when CMake finds
// Embree (RAYPACK_HAVE_EMBREE); otherwise the registry lists it as unavailable.
//
// Its frames: rtcIntersect1 primary rays and rtcOccluded1 shadow rays on the tree prepare() built
// at build quality medium, multithreaded with TBB over 8x8-pixel tiles; hits only (no image, no
// counters: Embree does not report its traversal). Its bench records: build qualities medium and
// high, each with rtcIntersect1/8/16 and rtcOccluded1/8 timed over one warm-up and N timed passes,
// and the medium tree's hits compared with the reference's (renderer/measure/agreement.h).
#include "renderer/error.h"
#include "renderer/tracers/tracer_rows.h"

#ifdef RAYPACK_HAVE_EMBREE
#include "renderer/camera.h"
#include "renderer/measure/agreement.h"
#include "renderer/measure/machine.h"
#include "renderer/measure/spread.h"
#include "shaders/intersect.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#endif

namespace raypack {

#ifndef RAYPACK_HAVE_EMBREE

bool embreeBuiltIn() { return false; }
std::string embreeBuildVersion() { return ""; }

std::unique_ptr<Tracer> makeEmbreeTracer(uint32_t) {
    throw Error("this raypack was built without Embree (install libembree-dev and rebuild)");
}

#else

bool embreeBuiltIn() { return true; }

std::string embreeBuildVersion() {
    return std::to_string(RTC_VERSION_MAJOR) + "." + std::to_string(RTC_VERSION_MINOR) + "." +
           std::to_string(RTC_VERSION_PATCH);
}

namespace {

constexpr uint32_t kTile = 8;  // tiles of 8x8 pixels; rtcIntersect8 packets are 4x2 of a tile

struct EmbreeDevice {
    RTCDevice device = nullptr;
    EmbreeDevice() {
        device = rtcNewDevice(nullptr);
        if (!device)
            throw Error("Embree: rtcNewDevice failed (error " + std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    }
    ~EmbreeDevice() { rtcReleaseDevice(device); }
    EmbreeDevice(const EmbreeDevice&) = delete;
    EmbreeDevice& operator=(const EmbreeDevice&) = delete;
};

struct EmbreeScene {
    RTCScene scene = nullptr;
    EmbreeScene() = default;
    ~EmbreeScene() { release(); }
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;
    void release() {
        if (scene) rtcReleaseScene(scene);
        scene = nullptr;
    }
};

void checkDevice(RTCDevice device, const char* what) {
    const RTCError error = rtcGetDeviceError(device);
    if (error != RTC_ERROR_NONE)
        throw Error(std::string("Embree: ") + what + " failed (RTCError " + std::to_string(int(error)) + ")");
}

// Builds the scene at `quality` and returns the seconds rtcCommitScene took (the build proper;
// filling the vertex and index buffers is not counted, as raypack's T_B does not count loading).
double buildScene(RTCDevice device, const Scene& scene, RTCBuildQuality quality, EmbreeScene& out) {
    out.release();
    out.scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(out.scene, quality);
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geometry, quality);
    auto* vertices =
        static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                    3 * sizeof(float), std::max<size_t>(scene.positions.size(), 1)));
    auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(uint32_t), scene.triangles.size()));
    checkDevice(device, "allocating the geometry buffers");
    for (size_t i = 0; i < scene.positions.size(); ++i) {
        vertices[3 * i + 0] = scene.positions[i].x;
        vertices[3 * i + 1] = scene.positions[i].y;
        vertices[3 * i + 2] = scene.positions[i].z;
    }
    for (size_t i = 0; i < scene.triangles.size(); ++i)
        for (int c = 0; c < 3; ++c) indices[3 * i + c] = scene.triangles[i][c];
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(out.scene, geometry);  // geometry ID 0 = raypack's single mesh
    rtcReleaseGeometry(geometry);
    const auto start = SteadyClock::now();
    rtcCommitScene(out.scene);
    const double seconds = secondsSince(start);
    checkDevice(device, "building the scene");
    return seconds;
}

struct Rays {
    GpuCamera camera;
    uint32_t width, height;
    glm::vec3 eye;
    glm::vec3 direction(uint32_t x, uint32_t y) const { return gpu::primaryRayDirection(camera, x, y); }
};

void setPrimary(RTCRayHit& rh, const Rays& rays, uint32_t x, uint32_t y) {
    const glm::vec3 d = rays.direction(x, y);
    rh.ray.org_x = rays.eye.x, rh.ray.org_y = rays.eye.y, rh.ray.org_z = rays.eye.z;
    rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

// One primary ray by rtcIntersect1: t (+inf on a miss) and the triangle (file order: the one
// geometry holds the scene's triangles in order).
struct PrimaryHit {
    float t = std::numeric_limits<float>::infinity();
    uint32_t prim = gpu::kNoHit;
};
PrimaryHit intersect1(RTCScene scene, RTCIntersectContext& context, const Rays& rays, uint32_t x, uint32_t y) {
    RTCRayHit rh;
    setPrimary(rh, rays, x, y);
    rtcIntersect1(scene, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {};
    return {rh.ray.tfar, rh.hit.primID};
}

// The shadow ray of the primary hit at `t` by rtcOccluded1, by raypack's shadow-ray rule
// (shaders/intersect.h): from the light to the hit point, ignoring what lies within kShadowRayGap
// of the point. Embree does not skip the hit triangle itself as raypack does; the gap keeps a
// planar triangle from occluding its own points all the same. True when occluded.
bool occluded1(RTCScene scene, RTCIntersectContext& context, const Rays& rays, const glm::vec3& light, uint32_t x,
               uint32_t y, float t) {
    const gpu::ShadowRay shadow = gpu::makeShadowRay(light, gpu::hitPosition(rays.eye, rays.direction(x, y), t), 0);
    if (gpu::isDegenerateShadowRay(shadow)) return false;  // p == light: lit
    RTCRay ray;
    ray.org_x = shadow.org.x, ray.org_y = shadow.org.y, ray.org_z = shadow.org.z;
    ray.dir_x = shadow.dir.x, ray.dir_y = shadow.dir.y, ray.dir_z = shadow.dir.z;
    ray.tnear = 0.0f;
    ray.tfar = shadow.tmax;
    ray.time = 0.0f;
    ray.mask = 0xFFFFFFFFu;
    ray.id = 0;
    ray.flags = 0;
    rtcOccluded1(scene, &context, &ray);
    // rtcOccluded1 sets tfar to -inf when it finds an occluder.
    return ray.tfar < 0.0f;
}

// Runs `pass` over every 8x8 tile of the image with TBB; returns the pass's wall clock.
template <typename TilePass>
double timeTiles(const Rays& rays, TilePass pass) {
    const uint32_t tilesX = (rays.width + kTile - 1) / kTile;
    const uint32_t tilesY = (rays.height + kTile - 1) / kTile;
    const auto start = SteadyClock::now();
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, tilesX * tilesY), [&](const tbb::blocked_range<uint32_t>& range) {
        for (uint32_t tile = range.begin(); tile != range.end(); ++tile) {
            const uint32_t x0 = (tile % tilesX) * kTile;
            const uint32_t y0 = (tile / tilesX) * kTile;
            pass(x0, y0, std::min(x0 + kTile, rays.width), std::min(y0 + kTile, rays.height));
        }
    });
    return secondsSince(start);
}

// Throughput of one way of tracing: rays per pass and the seconds of each timed pass.
struct EmbreeRate {
    uint64_t rays = 0;
    Spread seconds;
    double mraysPerSecond() const { return seconds.median > 0.0 ? double(rays) / seconds.median / 1e6 : 0.0; }
};

// One build quality: its build time and the tracing modes on that tree.
struct EmbreeQualityResults {
    std::string quality;  // "medium" or "high" (RTC_BUILD_QUALITY_*)
    double buildSeconds = 0.0;
    EmbreeRate intersect1;  // primary rays, rtcIntersect1
    EmbreeRate intersect8;  // primary rays, rtcIntersect8 packets of 4x2 pixels
    // Primary rays, rtcIntersect16 packets of 4x4 pixels; rays = 0 where this Embree build has no
    // 16-ray packets (RTC_DEVICE_PROPERTY_RAY16_SUPPORTED).
    EmbreeRate intersect16;
    bool intersect16Native = false;  // RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED
    EmbreeRate occluded1;            // shadow rays, rtcOccluded1
    EmbreeRate occluded8;            // shadow rays, rtcOccluded8 packets of 4x2 pixels
};

// Every pixel's primary ray by rtcIntersect1 into `primary`; returns the pass's wall clock.
double intersectPass(RTCScene scene, const Rays& rays, std::vector<PrimaryHit>& primary) {
    return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        for (uint32_t y = y0; y < y1; ++y)
            for (uint32_t x = x0; x < x1; ++x)
                primary[size_t(y) * rays.width + x] = intersect1(scene, context, rays, x, y);
    });
}

// The shadow ray of every primary hit by rtcOccluded1 into `shadowed` (1: occluded); returns the
// pass's wall clock.
double occludedPass(RTCScene scene, const Rays& rays, const glm::vec3& light, const std::vector<PrimaryHit>& primary,
                    std::vector<uint8_t>& shadowed) {
    return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        for (uint32_t y = y0; y < y1; ++y)
            for (uint32_t x = x0; x < x1; ++x) {
                const size_t pixel = size_t(y) * rays.width + x;
                if (primary[pixel].prim != gpu::kNoHit)
                    shadowed[pixel] = occluded1(scene, context, rays, light, x, y, primary[pixel].t);
            }
    });
}

template <typename Pass>
EmbreeRate timePasses(uint64_t rays, uint32_t repeats, Pass pass) {
    pass();  // warm-up, not timed
    std::vector<double> seconds;
    for (uint32_t i = 0; i < repeats; ++i) seconds.push_back(pass());
    return {rays, spreadOf(seconds)};
}

// Primary rays of the tile [x0, x1) x [y0, y1) in packets of `Lanes` rays, 4 pixels wide and
// `Rows` high (lanes outside the tile are invalid), traced by `intersect` (rtcIntersect8/16).
template <typename Packet, int Lanes, uint32_t Rows, typename Intersect>
void intersectPackets(RTCScene scene, const Rays& rays, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                      Intersect intersect) {
    static_assert(Lanes == 4 * int(Rows));
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    alignas(64) Packet packet;
    alignas(64) int valid[Lanes];
    for (uint32_t py = y0; py < y1; py += Rows)
        for (uint32_t px = x0; px < x1; px += 4) {
            for (int lane = 0; lane < Lanes; ++lane) {
                const uint32_t x = px + lane % 4, y = py + lane / 4;
                valid[lane] = (x < x1 && y < y1) ? -1 : 0;
                const glm::vec3 d = valid[lane] ? rays.direction(x, y) : glm::vec3(0, 0, 1);
                packet.ray.org_x[lane] = rays.eye.x;
                packet.ray.org_y[lane] = rays.eye.y;
                packet.ray.org_z[lane] = rays.eye.z;
                packet.ray.dir_x[lane] = d.x;
                packet.ray.dir_y[lane] = d.y;
                packet.ray.dir_z[lane] = d.z;
                packet.ray.tnear[lane] = 0.0f;
                packet.ray.tfar[lane] = std::numeric_limits<float>::infinity();
                packet.ray.time[lane] = 0.0f;
                packet.ray.mask[lane] = 0xFFFFFFFFu;
                packet.ray.id[lane] = 0;
                packet.ray.flags[lane] = 0;
                packet.hit.geomID[lane] = RTC_INVALID_GEOMETRY_ID;
                packet.hit.instID[0][lane] = RTC_INVALID_GEOMETRY_ID;
            }
            intersect(valid, scene, &context, &packet);
        }
}

// Embree's hits as HitRecords (as the reference fills them), for the comparison and for frames.
// `shadowed`: per pixel whether the shadow ray was occluded; nullptr when shadows are off.
std::vector<HitRecord> hitRecords(const Rays& rays, const std::vector<PrimaryHit>& primary,
                                  const std::vector<uint8_t>* shadowed) {
    std::vector<HitRecord> hits(primary.size());
    for (uint32_t y = 0; y < rays.height; ++y)
        for (uint32_t x = 0; x < rays.width; ++x) {
            const size_t pixel = size_t(y) * rays.width + x;
            const glm::vec3 d = rays.direction(x, y);
            HitRecord& h = hits[pixel];
            h = HitRecord{};
            h.orgX = rays.eye.x, h.orgY = rays.eye.y, h.orgZ = rays.eye.z;
            h.dirX = d.x, h.dirY = d.y, h.dirZ = d.z;
            h.t = primary[pixel].t;
            h.prim = primary[pixel].prim;
            h.shadow = gpu::kShadowNone;
            if (shadowed && h.prim != gpu::kNoHit)
                h.shadow = (*shadowed)[pixel] ? gpu::kShadowOccluded : gpu::kShadowLit;
        }
    return hits;
}

// Times every mode on `embree`, built at `qualityName` in `buildSeconds`. `hits`, when given,
// receives the rtcIntersect1 / rtcOccluded1 hits of the last timed pass, one per pixel.
EmbreeQualityResults measureQuality(RTCDevice device, const EmbreeScene& embree, double buildSeconds, const Rays& rays,
                                    const glm::vec3& light, bool shadows, const char* qualityName, uint32_t repeats,
                                    std::vector<HitRecord>* hits) {
    EmbreeQualityResults result;
    result.quality = qualityName;
    result.buildSeconds = buildSeconds;
    const size_t pixels = size_t(rays.width) * rays.height;
    // Primary hits: written by rtcIntersect1, read by the shadow pass.
    std::vector<PrimaryHit> primary(pixels);

    result.intersect1 = timePasses(pixels, repeats, [&] { return intersectPass(embree.scene, rays, primary); });

    // Packets of 4x2 pixels, the shape of an AVX2 8-wide packet over the tile.
    result.intersect8 = timePasses(pixels, repeats, [&] {
        return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
            intersectPackets<RTCRayHit8, 8, 2>(embree.scene, rays, x0, y0, x1, y1, rtcIntersect8);
        });
    });

    // Embree traces 16-ray packets natively with AVX-512 only; elsewhere it splits them (the
    // record says which, as embree_native_packet). An Embree built without 16-wide packets
    // reports an error at the first call, and the mode is left out.
    result.intersect16Native = rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0;
    rtcGetDeviceError(device);  // clears any earlier error
    {
        // Packets of 4x4 pixels over the tile.
        result.intersect16 = timePasses(pixels, repeats, [&] {
            return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
                intersectPackets<RTCRayHit16, 16, 4>(embree.scene, rays, x0, y0, x1, y1, rtcIntersect16);
            });
        });
        if (rtcGetDeviceError(device) != RTC_ERROR_NONE) result.intersect16 = {};
    }

    uint64_t shadowRays = 0;
    for (const PrimaryHit& h : primary) shadowRays += h.prim != gpu::kNoHit ? 1 : 0;
    std::vector<uint8_t> shadowed(pixels, 0);
    if (shadows) {
        result.occluded1 =
            timePasses(shadowRays, repeats, [&] { return occludedPass(embree.scene, rays, light, primary, shadowed); });
    }
    if (shadows) {
        result.occluded8 = timePasses(shadowRays, repeats, [&] {
            return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
                RTCIntersectContext context;
                rtcInitIntersectContext(&context);
                alignas(32) RTCRay8 packet;
                alignas(32) int valid[8];
                // Packets of 4x2 pixels, as rtcIntersect8; lanes whose pixel casts no shadow
                // ray are invalid.
                for (uint32_t py = y0; py < y1; py += 2)
                    for (uint32_t px = x0; px < x1; px += 4) {
                        int any = 0;
                        for (int lane = 0; lane < 8; ++lane) {
                            const uint32_t x = px + lane % 4, y = py + lane / 4;
                            gpu::ShadowRay shadow{light, glm::vec3(0, 0, 1), 0.0f, 0};
                            valid[lane] = 0;
                            if (x < x1 && y < y1) {
                                const size_t pixel = size_t(y) * rays.width + x;
                                if (primary[pixel].prim != gpu::kNoHit) {
                                    shadow = gpu::makeShadowRay(
                                        light, gpu::hitPosition(rays.eye, rays.direction(x, y), primary[pixel].t), 0);
                                    if (!gpu::isDegenerateShadowRay(shadow))
                                        valid[lane] = -1;
                                    else
                                        shadow.dir = glm::vec3(0, 0, 1);
                                }
                            }
                            any |= valid[lane];
                            packet.org_x[lane] = shadow.org.x;
                            packet.org_y[lane] = shadow.org.y;
                            packet.org_z[lane] = shadow.org.z;
                            packet.dir_x[lane] = shadow.dir.x;
                            packet.dir_y[lane] = shadow.dir.y;
                            packet.dir_z[lane] = shadow.dir.z;
                            packet.tnear[lane] = 0.0f;
                            packet.tfar[lane] = shadow.tmax;
                            packet.time[lane] = 0.0f;
                            packet.mask[lane] = 0xFFFFFFFFu;
                            packet.id[lane] = 0;
                            packet.flags[lane] = 0;
                        }
                        if (any) rtcOccluded8(valid, embree.scene, &context, &packet);
                    }
            });
        });
    }
    if (hits) *hits = hitRecords(rays, primary, shadows ? &shadowed : nullptr);
    return result;
}

class EmbreeTracer final : public Tracer {
public:
    explicit EmbreeTracer(uint32_t buildRepeats) : buildRepeats_(buildRepeats) {}
    std::string name() const override { return "embree"; }
    std::string kernel() const override { return "rtcIntersect1"; }
    TracerDevice device() const override { return TracerDevice::Cpu; }
    // The machine Embree ran on ("Embree, AMD EPYC (2 threads)"); the records of earlier sessions
    // said "CPU reference, ..." here, which named the wrong tracer.
    std::string describe(const RenderSettings&) const override { return describeCpuDevice("Embree"); }
    std::string driver() const override { return "Embree " + embreeBuildVersion(); }
    // Its own intersection, no accurate distance of raypack's.
    std::optional<std::string> hitDistance(const RenderSettings&) override { return std::nullopt; }
    TracerCapabilities capabilities() const override {
        TracerCapabilities c;
        c.hits = true;
        return c;
    }
    // Builds the medium-quality tree (Embree's default) from the scene's triangles in file order;
    // raypack's BVH is not used. Embree does not report the size of its tree (bytes = 0).
    Preparation prepare(const Scene& scene, const Bvh&) override {
        scene_ = &scene;
        Preparation p;
        p.seconds = mediumBuildSeconds_ = buildRepeated(scene, RTC_BUILD_QUALITY_MEDIUM, medium_);
        return p;
    }
    Frame render(const RenderSettings& settings, const FrameRequest& request) override {
        if (!scene_) throw Error("embree: no scene prepared");
        const auto frameStart = SteadyClock::now();
        const Rays rays = raysOf(settings);
        Frame frame;
        frame.width = settings.width;
        frame.height = settings.height;
        frame.light = lightPosition(settings.camera, scene_->bounds(), settings.lightHeight);
        std::vector<PrimaryHit> primary(size_t(rays.width) * rays.height);
        frame.timings.primarySeconds = intersectPass(medium_.scene, rays, primary);
        std::vector<uint8_t> shadowed(primary.size(), 0);
        if (settings.shadows)
            frame.timings.shadowSeconds = occludedPass(medium_.scene, rays, frame.light, primary, shadowed);
        if (request.hits) frame.hits = hitRecords(rays, primary, settings.shadows ? &shadowed : nullptr);
        frame.timings.totalSeconds = secondsSince(frameStart);
        return frame;
    }
    std::optional<nlohmann::json> peerRecords(const RenderSettings& settings, uint32_t repeats,
                                              const std::vector<HitRecord>& reference) override {
        if (!scene_) throw Error("embree: no scene prepared");
        const size_t pixels = size_t(settings.width) * settings.height;
        if (!reference.empty() && reference.size() != pixels)
            throw Error("Embree comparison: " + std::to_string(reference.size()) + " reference hits for a " +
                        std::to_string(settings.width) + "x" + std::to_string(settings.height) + " image");
        const Rays rays = raysOf(settings);
        const glm::vec3 light = lightPosition(settings.camera, scene_->bounds(), settings.lightHeight);
        std::vector<HitRecord> hits;
        std::vector<EmbreeQualityResults> qualities;
        qualities.push_back(measureQuality(device_.device, medium_, mediumBuildSeconds_, rays, light, settings.shadows,
                                           "medium", repeats, &hits));
        {
            EmbreeScene high;
            const double seconds = buildRepeated(*scene_, RTC_BUILD_QUALITY_HIGH, high);
            qualities.push_back(
                measureQuality(device_.device, high, seconds, rays, light, settings.shadows, "high", repeats, nullptr));
        }
        const HitAgreement agreement = reference.empty() ? HitAgreement{} : compareHits(hits, reference);
        return records(qualities, agreement, settings, repeats);
    }

private:
    // The median of buildRepeats_ builds (spreadOf's, as the bench's T_B); `out` holds the last.
    double buildRepeated(const Scene& scene, RTCBuildQuality quality, EmbreeScene& out) {
        std::vector<double> seconds;
        for (uint32_t r = 0; r < buildRepeats_; ++r) seconds.push_back(buildScene(device_.device, scene, quality, out));
        return spreadOf(seconds).median;
    }

    uint32_t buildRepeats_ = 1;
    static Rays raysOf(const RenderSettings& settings) {
        return {makeGpuCamera(settings.camera, settings.width, settings.height, settings.pixelJitter), settings.width,
                settings.height, settings.camera.eye};
    }
    nlohmann::json records(const std::vector<EmbreeQualityResults>& qualities, const HitAgreement& agreement,
                           const RenderSettings& settings, uint32_t repeats) const {
        nlohmann::json list = nlohmann::json::array();
        for (const EmbreeQualityResults& q : qualities) {
            const std::pair<const char*, const EmbreeRate*> modes[] = {{"rtcIntersect1", &q.intersect1},
                                                                       {"rtcIntersect8", &q.intersect8},
                                                                       {"rtcIntersect16", &q.intersect16},
                                                                       {"rtcOccluded1", &q.occluded1},
                                                                       {"rtcOccluded8", &q.occluded8}};
            for (const auto& [kernel, rate] : modes) {
                const bool shadow = std::string(kernel).rfind("rtcOccluded", 0) == 0;
                if (shadow && !settings.shadows) continue;
                if (rate->rays == 0 && !shadow) continue;  // rtcIntersect16 not in this Embree build
                nlohmann::json r;
                r["tracer"] = name();
                r["device"] = describe(settings);
                r["driver"] = driver();
                r["embree_quality"] = q.quality;
                r["kernel"] = kernel;
                r["packet"] = nullptr;
                if (std::string(kernel) == "rtcIntersect16") r["embree_native_packet"] = q.intersect16Native;
                r["ray_kind"] = shadow ? "shadow" : "primary";
                r["width_px"] = settings.width;
                r["height_px"] = settings.height;
                r["repeats"] = repeats;
                r["threads"] = uint32_t(tbb::info::default_concurrency());
                r["t_b_s"] = q.buildSeconds;
                r["n_q_rays"] = rate->rays;
                r["t_k_s"] = rate->seconds.median;
                r["t_k_min_s"] = rate->seconds.min;
                r["t_k_max_s"] = rate->seconds.max;
                r["t_r_us_per_ray"] = rate->rays ? rate->seconds.median / double(rate->rays) * 1e6 : 0.0;
                r["perf_mrays_s"] = rate->mraysPerSecond();
                r["hits_compared"] = agreement.comparedRays;
                r["hits_agree_share"] = agreement.rayShare();
                r["hits_max_rel_t_error"] = agreement.maxRelativeTError;
                r["shadows_compared"] = agreement.comparedShadows;
                r["shadows_agree_share"] = agreement.shadowShare();
                list.push_back(r);
            }
        }
        return list;
    }

    EmbreeDevice device_;
    EmbreeScene medium_;
    double mediumBuildSeconds_ = 0.0;
    const Scene* scene_ = nullptr;
};

}  // namespace

std::unique_ptr<Tracer> makeEmbreeTracer(uint32_t buildRepeats) {
    return std::make_unique<EmbreeTracer>(std::max(buildRepeats, 1u));
}

#endif  // RAYPACK_HAVE_EMBREE

}  // namespace raypack
