// Names in the clustered trees (gpu-ploc, gpu-hploc; shaders/lbvh.h) as cluster_layout.comp and
// treelet.comp read them. Records are ploc.comp's and hploc.comp's: children named as lbvh.comp
// names them (an inner node by its record, sorted triangle k as n - 1 + k), the triangle count in z;
// the root is record 0. Boxes are by cluster id: sorted triangle k is id k, record r is id 2n - 2 - r.
// Include after `params`, `inner` and `state` are declared, and `innerParents` and `leafParents`
// unless RAYPACK_CLUSTER_TREE_NO_PARENTS is defined (then parentOf is not).
#ifndef RAYPACK_SHADERS_CLUSTER_TREE_H
#define RAYPACK_SHADERS_CLUSTER_TREE_H

uint n() { return params.counts.x; }
bool isTriangle(uint name) { return name >= n() - 1u; }
uint boxIndex(uint name) { return isTriangle(name) ? name - (n() - 1u) : 2u * n() - 2u - name; }
#ifndef RAYPACK_CLUSTER_TREE_NO_PARENTS
uint parentOf(uint name) { return isTriangle(name) ? leafParents[name - (n() - 1u)] : innerParents[name]; }
#endif
uint countOf(uint name) { return isTriangle(name) ? 1u : inner[name].z; }

// The unit union areas are compared in (lbvh.h plocAreaUnit), from the scene's bounds in the state.
float sceneAreaUnit() {
    vec3 sceneLo, sceneHi;
    for (uint a = 0u; a < 3u; ++a) {
        sceneLo[a] = lbvhFromOrderedBits(state[kLbvhStateBoxLo + a]);
        sceneHi[a] = lbvhFromOrderedBits(state[kLbvhStateBoxHi + a]);
    }
    return plocAreaUnit(sceneLo, sceneHi);
}

#endif
