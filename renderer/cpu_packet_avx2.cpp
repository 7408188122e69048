// The packet kernel at 8 lanes (AVX2): renderer/cpu_packet_simd.inl compiled for that
// target only (a function attribute through the pragma, not a flag for the whole file, so that
// nothing this file shares with others, such as std or glm code, is built for it). No "fma".
#include "renderer/cpu_packet_kernel.h"

#include "renderer/error.h"
#include "shaders/intersect.h"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
// GCC's target pragma; clang ignores it and takes its own attribute pragma instead.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
#define RAYPACK_PACKET_AVX2 1
#include "renderer/cpu_packet_simd.inl"

namespace raypack::packet_detail {

void tracePrimaryPacketAvx2(const PacketFrame& frame, uint32_t x0, uint32_t y0) { tracePrimary(frame, x0, y0); }

void traceShadowPacketAvx2(const PacketFrame& frame, uint32_t x0, uint32_t y0) { traceShadow(frame, x0, y0); }

}  // namespace raypack::packet_detail

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif

#else  // not x86: cpu_packet_tracer.cpp never selects this width (cpuHas), the scalar one runs

namespace raypack::packet_detail {

void tracePrimaryPacketAvx2(const PacketFrame&, uint32_t, uint32_t) {
    RAYPACK_CHECK_MSG(false, "no Avx2 kernel on this architecture");
}

void traceShadowPacketAvx2(const PacketFrame&, uint32_t, uint32_t) {
    RAYPACK_CHECK_MSG(false, "no Avx2 kernel on this architecture");
}

}  // namespace raypack::packet_detail

#endif
