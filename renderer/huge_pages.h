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

}  // namespace raypack
