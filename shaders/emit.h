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

// This invocation made `leaves` leaves at depth `depth`; summed over the subgroup first, so that one
// invocation of it adds to each word. Every invocation of the subgroup must call it.
void addLeaves(uint leaves, uint depth) {
    const uint subgroupLeaves = subgroupAdd(leaves);
    const uint subgroupDepths = subgroupAdd(leaves * depth);
    const uint deepest = subgroupMax(leaves > 0u ? depth : 0u);
    if (subgroupElect() && subgroupLeaves > 0u) {
        atomicAdd(state[kLbvhStateLeafCount], subgroupLeaves);
        // The depth sum in two words: the low word's carry goes to the high one.
        const uint low = atomicAdd(state[kLbvhStateDepthSum], subgroupDepths);
        if (low + subgroupDepths < low) atomicAdd(state[kLbvhStateDepthSum + 1u], 1u);
        atomicMax(state[kLbvhStateMaxDepth], deepest);
    }
}

#endif
