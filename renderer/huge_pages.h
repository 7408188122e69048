#pragma once
// Transparent huge pages for large buffers, used by the BVH builders (renderer/bvh_build.h) and the
// scene loaders (scenes/): one definition for both.
#include <cstddef>

namespace raypack {

// Asks the kernel to back [data, data + bytes) with 2 MiB transparent huge pages (Linux, THP in
// "madvise" or "always" mode) before it is first written. On the virtual machines raypack is
// measured on, first touching a 4 KiB page costs about 10 us: a third of the exact builder's time
// on Conference before this, and loading a 13M-triangle PLY writes about 500 MB of fresh memory
// (file buffer, positions, triangles), 512 times fewer faults with 2 MiB pages.
// Only the whole 2 MiB-aligned blocks inside the range are advised: only those can become huge
// pages, and advising past them to 4 KiB boundaries (as the loaders' copy did) would split the
// mapping inside a 2 MiB block, which keeps that block in small pages even in THP "always" mode,
// and adds a mapping (towards vm.max_map_count) for nothing. A range without such a block is left
// alone. A hint only: nothing changes where it is not honoured.
void adviseHugePages(const void* data, size_t bytes);

// Storage of `bytes` bytes, aligned to 64, for a build's large buffers (its scratch, the node array):
// from 2 MiB on (Linux), a private anonymous mapping of whole 2 MiB blocks on a 2 MiB boundary,
// advised to huge pages; below that, elsewhere and under AddressSanitizer, operator new. Throws
// std::bad_alloc. freeLarge keeps up to 8 such mappings (4 GiB) for later requests of at least
// half their size, their pages handed to the kernel with MADV_FREE: the kernel takes them when it
// needs memory, and until then they count in the process's resident size and a reuse costs no
// fault. A build then costs the same whatever the process allocated before, and a repeated build
// reuses its predecessor's pages. With the C library's heap, whether a build reused pages already
// faulted in or mapped fresh ones depended on what the process had freed earlier: on this 2-core
// VM the same Sibenik build took 17.9 ms after loading Sponza and 33.3 ms after a small generated
// scene, nearly all of the difference page faults (docs/bvh.md). Embree maps its build memory in
// huge pages too.
void* allocateLarge(size_t bytes);
// Returns storage from allocateLarge(bytes), with the same `bytes`. Containers use both through
// UninitializedAllocator (renderer/bvh.h).
void freeLarge(void* data, size_t bytes) noexcept;

}  // namespace raypack
