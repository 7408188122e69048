// What the GPU builders' two emissions share (lbvh.comp's, level by level; cluster_layout.comp's, in
// one dispatch): the tracers' node records (shaders/gpu_types.h) and the leaf statistics
// (shaders/lbvh.h's kLbvhStateLeafCount, kLbvhStateDepthSum, kLbvhStateMaxDepth). Include after the
// `state` buffer, with GL_KHR_shader_subgroup_arithmetic enabled.
#ifndef RAYPACK_SHADERS_EMIT_H
#define RAYPACK_SHADERS_EMIT_H

GpuNode innerNode(vec3 lo, vec3 hi, uint left) {
    GpuNode node;
    node.lo = vec4(lo, uintBitsToFloat(left));
    node.hi = vec4(hi, uintBitsToFloat(0u));
    return node;
}
GpuNode leafNode(vec3 lo, vec3 hi, uint first, uint count) {
    GpuNode node;
    node.lo = vec4(lo, uintBitsToFloat(first));
    node.hi = vec4(hi, uintBitsToFloat(count));
    return node;
}

// The statistics of this invocation's emission: `leaves` leaves at depth `depth`, `inners` inner
// nodes. Summed over the subgroup, then over the workgroup, so that one invocation of each workgroup
// adds to each word (a few hundred thousand atomics on one word cost a millisecond at 13M
// triangles); groupSums holds each subgroup's (leaves, their depths' sum, the deepest, inner nodes).
// Every invocation of the workgroup must call it: it has a barrier.
shared uvec4 groupSums[gl_WorkGroupSize.x];
void addStatistics(uint leaves, uint depth, uint inners) {
    const uvec4 sums = uvec4(subgroupAdd(leaves), subgroupAdd(leaves * depth), subgroupMax(leaves > 0u ? depth : 0u),
                             subgroupAdd(inners));
    if (subgroupElect()) groupSums[gl_SubgroupID] = sums;
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        uvec4 all = uvec4(0u);
        for (uint s = 0u; s < gl_NumSubgroups; ++s)
            all = uvec4(all.x + groupSums[s].x, all.y + groupSums[s].y, max(all.z, groupSums[s].z),
                        all.w + groupSums[s].w);
        if (all.x > 0u) {
            atomicAdd(state[kLbvhStateLeafCount], all.x);
            // The depth sum in two words: the low word's carry goes to the high one.
            const uint low = atomicAdd(state[kLbvhStateDepthSum], all.y);
            if (low + all.y < low) atomicAdd(state[kLbvhStateDepthSum + 1u], 1u);
            atomicMax(state[kLbvhStateMaxDepth], all.z);
        }
        if (all.w > 0u) atomicAdd(state[kLbvhStateInnerCount], all.w);
    }
}

#endif
