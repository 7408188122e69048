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
// triangles). Every invocation of the workgroup must call it: it has a barrier.
shared uint groupLeaves[gl_WorkGroupSize.x], groupDepths[gl_WorkGroupSize.x], groupDeepest[gl_WorkGroupSize.x],
    groupInners[gl_WorkGroupSize.x];
void addStatistics(uint leaves, uint depth, uint inners) {
    const uint subgroupLeaves = subgroupAdd(leaves), subgroupDepths = subgroupAdd(leaves * depth);
    const uint deepest = subgroupMax(leaves > 0u ? depth : 0u), subgroupInners = subgroupAdd(inners);
    if (subgroupElect()) {
        groupLeaves[gl_SubgroupID] = subgroupLeaves;
        groupDepths[gl_SubgroupID] = subgroupDepths;
        groupDeepest[gl_SubgroupID] = deepest;
        groupInners[gl_SubgroupID] = subgroupInners;
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        uint total = 0u, depths = 0u, deepestOfAll = 0u, innerTotal = 0u;
        for (uint s = 0u; s < gl_NumSubgroups; ++s) {
            total += groupLeaves[s];
            depths += groupDepths[s];
            deepestOfAll = max(deepestOfAll, groupDeepest[s]);
            innerTotal += groupInners[s];
        }
        if (total > 0u) {
            atomicAdd(state[kLbvhStateLeafCount], total);
            // The depth sum in two words: the low word's carry goes to the high one.
            const uint low = atomicAdd(state[kLbvhStateDepthSum], depths);
            if (low + depths < low) atomicAdd(state[kLbvhStateDepthSum + 1u], 1u);
            atomicMax(state[kLbvhStateMaxDepth], deepestOfAll);
        }
        if (innerTotal > 0u) atomicAdd(state[kLbvhStateInnerCount], innerTotal);
    }
}

#endif
