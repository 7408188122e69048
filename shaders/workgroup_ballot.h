// A ballot over a whole workgroup of at most 32 invocations (hploc.comp, treelet.comp): bit i for
// invocation i. Include after the shader's local_size layout, with GL_KHR_shader_subgroup_ballot
// enabled; every invocation of the workgroup must call it, since it has barriers.
#ifndef RAYPACK_SHADERS_WORKGROUP_BALLOT_H
#define RAYPACK_SHADERS_WORKGROUP_BALLOT_H

shared uint groupBits[gl_WorkGroupSize.x];
uint groupBallot(bool value) {
    const uvec4 bits = subgroupBallot(value);
    if (subgroupElect())
        groupBits[gl_SubgroupID] =
            gl_SubgroupSize >= gl_WorkGroupSize.x ? bits.x : bits.x << (gl_SubgroupID * gl_SubgroupSize);
    barrier();
    uint mask = 0u;
    for (uint s = 0u; s < gl_NumSubgroups; ++s) mask |= groupBits[s];
    barrier();
    return mask;
}

#endif
