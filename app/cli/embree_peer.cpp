#include "app/cli/embree_peer.h"

#include "renderer/camera.h"
#include "renderer/error.h"
#include "shaders/intersect.h"

#ifdef RAYPACK_HAVE_EMBREE
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

namespace raypack::cli {

#ifndef RAYPACK_HAVE_EMBREE

bool embreeAvailable() { return false; }

EmbreeResults runEmbreePeer(const Scene&, const RenderSettings&, const std::vector<HitRecord>&, uint32_t) {
    throw Error("this raypack-cli was built without Embree (install libembree-dev and rebuild)");
}

#else

bool embreeAvailable() { return true; }

namespace {

constexpr uint32_t kTile = 8;  // tiles of 8x8 pixels; rtcIntersect8 packets are 4x2 of a tile

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

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
    ~EmbreeScene() {
        if (scene) rtcReleaseScene(scene);
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
    const auto start = Clock::now();
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

// Runs `pass` over every 8x8 tile of the image with TBB; returns the pass's wall clock.
template <typename TilePass>
double timeTiles(const Rays& rays, TilePass pass) {
    const uint32_t tilesX = (rays.width + kTile - 1) / kTile;
    const uint32_t tilesY = (rays.height + kTile - 1) / kTile;
    const auto start = Clock::now();
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, tilesX * tilesY), [&](const tbb::blocked_range<uint32_t>& range) {
        for (uint32_t tile = range.begin(); tile != range.end(); ++tile) {
            const uint32_t x0 = (tile % tilesX) * kTile;
            const uint32_t y0 = (tile / tilesX) * kTile;
            pass(x0, y0, std::min(x0 + kTile, rays.width), std::min(y0 + kTile, rays.height));
        }
    });
    return secondsSince(start);
}

template <typename Pass>
EmbreeRate timePasses(uint64_t rays, uint32_t repeats, Pass pass) {
    pass();  // warm-up, not timed
    std::vector<double> seconds;
    for (uint32_t i = 0; i < repeats; ++i) seconds.push_back(pass());
    return {rays, spreadOf(seconds)};
}

EmbreeQualityResults measureQuality(RTCDevice device, const Scene& scene, const Rays& rays, const glm::vec3& light,
                                    bool shadows, RTCBuildQuality quality, const char* qualityName, uint32_t repeats,
                                    std::vector<float>* primaryT, std::vector<uint8_t>* occluded) {
    EmbreeQualityResults result;
    result.quality = qualityName;
    EmbreeScene embree;
    result.buildSeconds = buildScene(device, scene, quality, embree);
    const size_t pixels = size_t(rays.width) * rays.height;
    // Hit distances of the primary rays: written by rtcIntersect1, read by the shadow pass.
    std::vector<float> hitT(pixels, std::numeric_limits<float>::infinity());

    result.intersect1 = timePasses(pixels, repeats, [&] {
        return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            RTCRayHit rh;
            for (uint32_t y = y0; y < y1; ++y)
                for (uint32_t x = x0; x < x1; ++x) {
                    setPrimary(rh, rays, x, y);
                    rtcIntersect1(embree.scene, &context, &rh);
                    hitT[size_t(y) * rays.width + x] =
                        rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? std::numeric_limits<float>::infinity() : rh.ray.tfar;
                }
        });
    });

    result.intersect8 = timePasses(pixels, repeats, [&] {
        return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            alignas(32) RTCRayHit8 packet;
            alignas(32) int valid[8];
            // Packets of 4x2 pixels, the shape of an AVX2 8-wide packet over the tile.
            for (uint32_t py = y0; py < y1; py += 2)
                for (uint32_t px = x0; px < x1; px += 4) {
                    for (int lane = 0; lane < 8; ++lane) {
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
                    rtcIntersect8(valid, embree.scene, &context, &packet);
                }
        });
    });

    // Embree traces 16-ray packets natively with AVX-512 only; elsewhere it splits them (the
    // record says which, as embree_native_packet). An Embree built without 16-wide packets
    // reports an error at the first call, and the mode is left out.
    result.intersect16Native = rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0;
    rtcGetDeviceError(device);  // clears any earlier error
    {
        result.intersect16 = timePasses(pixels, repeats, [&] {
            return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
                RTCIntersectContext context;
                rtcInitIntersectContext(&context);
                alignas(64) RTCRayHit16 packet;
                alignas(64) int valid[16];
                // Packets of 4x4 pixels over the tile.
                for (uint32_t py = y0; py < y1; py += 4)
                    for (uint32_t px = x0; px < x1; px += 4) {
                        for (int lane = 0; lane < 16; ++lane) {
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
                        rtcIntersect16(valid, embree.scene, &context, &packet);
                    }
            });
        });
        if (rtcGetDeviceError(device) != RTC_ERROR_NONE) result.intersect16 = {};
    }

    uint64_t shadowRays = 0;
    for (float t : hitT) shadowRays += std::isfinite(t) ? 1 : 0;
    std::vector<uint8_t> shadowed(pixels, 0);
    if (shadows) {
        result.occluded1 = timePasses(shadowRays, repeats, [&] {
            return timeTiles(rays, [&](uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1) {
                RTCIntersectContext context;
                rtcInitIntersectContext(&context);
                RTCRay ray;
                for (uint32_t y = y0; y < y1; ++y)
                    for (uint32_t x = x0; x < x1; ++x) {
                        const size_t pixel = size_t(y) * rays.width + x;
                        if (!std::isfinite(hitT[pixel])) continue;
                        // raypack's shadow-ray rule (shaders/intersect.h): from the light to
                        // the hit point, ignoring what lies within kShadowRayGap of the point.
                        // Embree does not skip the hit triangle itself as raypack does; the gap
                        // keeps a planar triangle from occluding its own points all the same.
                        const gpu::ShadowRay shadow =
                            gpu::makeShadowRay(light, gpu::hitPosition(rays.eye, rays.direction(x, y), hitT[pixel]), 0);
                        if (gpu::isDegenerateShadowRay(shadow)) continue;  // p == light: lit
                        ray.org_x = shadow.org.x, ray.org_y = shadow.org.y, ray.org_z = shadow.org.z;
                        ray.dir_x = shadow.dir.x, ray.dir_y = shadow.dir.y, ray.dir_z = shadow.dir.z;
                        ray.tnear = 0.0f;
                        ray.tfar = shadow.tmax;
                        ray.time = 0.0f;
                        ray.mask = 0xFFFFFFFFu;
                        ray.id = 0;
                        ray.flags = 0;
                        rtcOccluded1(embree.scene, &context, &ray);
                        // rtcOccluded1 sets tfar to -inf when it finds an occluder.
                        shadowed[pixel] = ray.tfar < 0.0f ? 1 : 0;
                    }
            });
        });
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
                                if (std::isfinite(hitT[pixel])) {
                                    shadow = gpu::makeShadowRay(
                                        light, gpu::hitPosition(rays.eye, rays.direction(x, y), hitT[pixel]), 0);
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
    if (primaryT) *primaryT = std::move(hitT);
    if (occluded) *occluded = std::move(shadowed);
    return result;
}

}  // namespace

EmbreeResults runEmbreePeer(const Scene& scene, const RenderSettings& settings,
                            const std::vector<HitRecord>& referenceHits, uint32_t repeats) {
    const size_t pixels = size_t(settings.width) * settings.height;
    if (!referenceHits.empty() && referenceHits.size() != pixels)
        throw Error("Embree comparison: " + std::to_string(referenceHits.size()) + " reference hits for a " +
                    std::to_string(settings.width) + "x" + std::to_string(settings.height) + " image");
    EmbreeResults results;
    results.version = std::to_string(RTC_VERSION_MAJOR) + "." + std::to_string(RTC_VERSION_MINOR) + "." +
                      std::to_string(RTC_VERSION_PATCH);
    results.threads = uint32_t(tbb::info::default_concurrency());

    EmbreeDevice device;
    const Rays rays{makeGpuCamera(settings.camera, settings.width, settings.height, settings.pixelJitter),
                    settings.width, settings.height, settings.camera.eye};
    const glm::vec3 light = lightPosition(settings.camera, scene.bounds(), settings.lightHeight);

    std::vector<float> primaryT;
    std::vector<uint8_t> occluded;
    results.qualities.push_back(measureQuality(device.device, scene, rays, light, settings.shadows,
                                               RTC_BUILD_QUALITY_MEDIUM, "medium", repeats, &primaryT, &occluded));
    results.qualities.push_back(measureQuality(device.device, scene, rays, light, settings.shadows,
                                               RTC_BUILD_QUALITY_HIGH, "high", repeats, nullptr, nullptr));

    for (size_t i = 0; i < referenceHits.size(); ++i) {
        const HitRecord& ref = referenceHits[i];
        const bool refHit = ref.prim != gpu::kNoHit;
        const bool embreeHit = std::isfinite(primaryT[i]);
        ++results.comparedRays;
        if (!refHit || !embreeHit) {
            results.agreeingRays += refHit == embreeHit ? 1 : 0;
            continue;
        }
        const double error = std::abs(double(primaryT[i]) - double(ref.t)) / std::max(std::abs(double(ref.t)), 1e-30);
        results.maxRelativeTError = std::max(results.maxRelativeTError, error);
        results.agreeingRays += error <= 1e-4 ? 1 : 0;
        if (settings.shadows && ref.shadow != gpu::kShadowNone) {
            ++results.comparedShadows;
            const bool refOccluded = ref.shadow == gpu::kShadowOccluded;
            results.agreeingShadows += refOccluded == (occluded[i] != 0) ? 1 : 0;
        }
    }
    return results;
}

#endif  // RAYPACK_HAVE_EMBREE

}  // namespace raypack::cli
