#pragma once
// Inside renderer/tracers: what each tracer's file gives the registry (registry.cpp), one factory
// per file, and what two of them share. Programs use registry.h.
#include "renderer/cpu_tracer.h"
#include "renderer/tracers/tracer.h"
#include "renderer/vk/context.h"

#include <memory>
#include <optional>
#include <string>

namespace raypack {

std::unique_ptr<Tracer> makeCpuReferenceTracer();
std::unique_ptr<Tracer> makeCpuPacketTracer();
// `kernel`: the packet kernel (Gunther et al. 2007), the single-ray kernel (Aila and Laine 2009) or
// the hybrid, on `context`, which must outlive the tracer; `bvhWidth` 8 (single-ray kernel only):
// the compressed 8-wide tree made at upload (gpu-cwbvh).
std::unique_ptr<Tracer> makeGpuKernelTracer(const vk::VulkanContext& context, KernelKind kernel, uint32_t bvhWidth = 2);
// Throws RtPeerUnsupported where `context` cannot run the driver's ray tracing.
std::unique_ptr<Tracer> makeDriverRtTracer(const vk::VulkanContext& context);
// Throws raypack::Error in a build without Embree. Each quality's tree is built `buildRepeats`
// times; its build time is the median.
std::unique_ptr<Tracer> makeEmbreeTracer(uint32_t buildRepeats = 1);
bool embreeBuiltIn();
std::string embreeBuildVersion();  // "3.13.5"; "" without Embree

// The two CPU tracers' prepare(): the CpuSceneView both trace.
Preparation prepareCpuSceneView(std::optional<CpuSceneView>& view, const Scene& scene, const Bvh& bvh);

}  // namespace raypack
