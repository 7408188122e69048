// The packet kernel at 8 lanes (AVX2): renderer/cpu_packet_simd.inl compiled for that
// target only (a function attribute through the pragma, not a flag for the whole file, so that
// nothing this file shares with others, such as std or glm code, is built for it). No "fma".
#include "renderer/cpu_packet_kernel.h"

#include "renderer/error.h"
#include "shaders/intersect.h"

#include <immintrin.h>

#include <algorithm>
#include <limits>
#include <cstdint>
#include <vector>

#pragma GCC push_options
#pragma GCC target("avx2")
#define RAYPACK_PACKET_AVX2 1
#include "renderer/cpu_packet_simd.inl"

namespace raypack::packet_detail {

void tracePrimaryPacketAvx2(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    tracePrimary(frame, x0, y0);
}

void traceShadowPacketAvx2(const PacketFrame& frame, uint32_t x0, uint32_t y0) {
    traceShadow(frame, x0, y0);
}

}  // namespace raypack::packet_detail

#pragma GCC pop_options
