// One language for the code the GPU and the CPU share (see ../shared/STYLE.md, "One definition of
// what the GPU reads"). A header under shaders/ that includes this file compiles both as GLSL 4.60
// (glslangValidator, GL_GOOGLE_include_directive) and as C++20 (glm standing in for GLSL's types).
// Rules for such headers:
//  - include guards, not #pragma once (GLSL has none);
//  - struct members are scalars, vec4 or uvec4, never bare vec3 (std430 pads vec3 to 16 bytes);
//  - no constructors with braces, no swizzles beyond .x/.y/.z/.w, float literals as 1.0f;
//  - every function is declared RP_FUNC (inline in C++);
//  - parameters passed by reference are declared with RP_INOUT(T) / RP_OUT(T);
//  - everything between RP_BEGIN_NAMESPACE and RP_END_NAMESPACE lands in raypack::gpu in C++.
#ifndef RAYPACK_SHADERS_COMMON_H
#define RAYPACK_SHADERS_COMMON_H

#ifdef __cplusplus
#include <glm/glm.hpp>
#include <glm/gtc/type_ptr.hpp>

#include <cmath>
#include <cstdint>

#define RP_INOUT(T) T&
#define RP_OUT(T) T&
#define RP_PRECISE
#define RP_FUNC inline
#define RP_BEGIN_NAMESPACE namespace raypack::gpu {
#define RP_END_NAMESPACE }
// Sizes and offsets of shared structures are checked on the C++ side.
#define RP_CHECK_SIZE(T, bytes) static_assert(sizeof(T) == (bytes), #T " must be " #bytes " bytes")
#define RP_CHECK_OFFSET(T, member, bytes) \
    static_assert(offsetof(T, member) == (bytes), #T "::" #member " must be at byte " #bytes)

RP_BEGIN_NAMESPACE
using uint = uint32_t;
using glm::abs;
using glm::clamp;
using glm::cross;
using glm::dot;
using glm::floatBitsToUint;
using glm::inversesqrt;
using glm::ivec2;
using glm::ivec3;
using glm::ivec4;
using glm::length;
using glm::log2;
using glm::max;
using glm::min;
using glm::mix;
using glm::normalize;
using glm::pow;
using glm::reflect;
using glm::sign;
using glm::sqrt;
using glm::uintBitsToFloat;
using glm::uvec2;
using glm::uvec3;
using glm::uvec4;
using glm::vec2;
using glm::vec3;
using glm::vec4;
RP_END_NAMESPACE

#else  // GLSL

#define RP_INOUT(T) inout T
#define RP_OUT(T) out T
// `precise`: the compiler may not fuse this value's products and sums into multiply-adds, nor
// reorder them, so it gets the bits the CPU's ISO C++ (-ffp-contract=off) gets. Vulkan rounds +, -
// and * correctly; division, sqrt and fma it does not promise to.
#define RP_PRECISE precise
#define RP_FUNC
#define RP_BEGIN_NAMESPACE
#define RP_END_NAMESPACE
#define RP_CHECK_SIZE(T, bytes)
#define RP_CHECK_OFFSET(T, member, bytes)

#endif

#endif  // RAYPACK_SHADERS_COMMON_H
