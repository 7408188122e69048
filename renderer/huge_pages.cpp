#include "renderer/huge_pages.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace raypack {

void adviseHugePages(const void* data, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr uintptr_t kHugePage = uintptr_t(2) << 20;
    if (bytes < kHugePage) return;
    const uintptr_t begin = (uintptr_t(data) + kHugePage - 1) & ~(kHugePage - 1);
    const uintptr_t end = (uintptr_t(data) + bytes) & ~(kHugePage - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
    (void)data;
    (void)bytes;
#endif
}

namespace {

constexpr size_t kHugePageBytes = size_t(2) << 20;
constexpr std::align_val_t kLargeAlignment{64};

// Unused where the mappings are off (under AddressSanitizer).
[[maybe_unused]] size_t mappedBytes(size_t bytes) { return (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1); }

// Under AddressSanitizer the storage stays operator new's, which the sanitizer checks.
#if defined(__SANITIZE_ADDRESS__)
#define RAYPACK_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RAYPACK_ADDRESS_SANITIZER 1
#endif
#endif
#if defined(__linux__) && defined(MADV_HUGEPAGE) && !defined(RAYPACK_ADDRESS_SANITIZER)
#define RAYPACK_LARGE_MAPPINGS 1
#endif

#if defined(RAYPACK_LARGE_MAPPINGS)
// Mappings freeLarge gave back, kept for the next build: their pages were handed to the kernel with
// MADV_FREE (it takes them whenever it needs memory, and until then a new write costs no fault, no
// clearing), at most kKeptMappings of them and kKeptBytes in all, the oldest unmapped first.
constexpr size_t kKeptMappings = 8;
constexpr size_t kKeptBytes = size_t(4) << 30;

struct Mapping {
    void* data;
    size_t bytes;
};

struct KeptMappings {
    std::mutex mutex;
    std::vector<Mapping> mappings;  // oldest first; never reallocated (keep() must not throw)
    size_t bytes = 0;

    KeptMappings() { mappings.reserve(kKeptMappings + 1); }

    // A kept mapping of at least `bytes` and at most twice that, the smallest such, or null.
    void* take(size_t bytes) {
        std::lock_guard lock(mutex);
        size_t best = mappings.size();
        for (size_t i = 0; i < mappings.size(); ++i)
            if (mappings[i].bytes >= bytes && mappings[i].bytes / 2 <= bytes &&
                (best == mappings.size() || mappings[i].bytes < mappings[best].bytes))
                best = i;
        if (best == mappings.size()) return nullptr;
        // The caller frees it with its own size: unmap what lies past that now.
        const Mapping mapping = mappings[best];
        mappings.erase(mappings.begin() + ptrdiff_t(best));
        this->bytes -= mapping.bytes;
        if (mapping.bytes > bytes) munmap(static_cast<char*>(mapping.data) + bytes, mapping.bytes - bytes);
        return mapping.data;
    }
    void keep(void* data, size_t bytes) noexcept {
        madvise(data, bytes, MADV_FREE);
        std::array<Mapping, kKeptMappings + 1> dropped;
        size_t droppedCount = 0;
        {
            std::lock_guard lock(mutex);
            mappings.push_back({data, bytes});
            this->bytes += bytes;
            while (mappings.size() > kKeptMappings || this->bytes > kKeptBytes) {
                dropped[droppedCount++] = mappings.front();
                this->bytes -= mappings.front().bytes;
                mappings.erase(mappings.begin());
            }
        }
        for (size_t i = 0; i < droppedCount; ++i) munmap(dropped[i].data, dropped[i].bytes);
    }
};

KeptMappings& keptMappings() {
    static KeptMappings* const kept = new KeptMappings;  // never destroyed: frees may come during exit
    return *kept;
}
#endif

}  // namespace

void* allocateLarge(size_t bytes) {
#if defined(RAYPACK_LARGE_MAPPINGS)
    if (bytes >= kHugePageBytes) {
        if (bytes > SIZE_MAX - 2 * kHugePageBytes) throw std::bad_alloc();
        const size_t kept = mappedBytes(bytes);
        if (void* const reused = keptMappings().take(kept)) return reused;
        // One block more than needed, then the unaligned head and the tail unmapped, so that the
        // kept range starts on a 2 MiB boundary and every block of it can be a huge page.
        const size_t mapped = kept + kHugePageBytes;
        void* const raw = mmap(nullptr, mapped, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED) throw std::bad_alloc();
        const uintptr_t begin = uintptr_t(raw);
        const uintptr_t aligned = (begin + kHugePageBytes - 1) & ~uintptr_t(kHugePageBytes - 1);
        if (aligned > begin) munmap(raw, aligned - begin);
        const uintptr_t tail = aligned + kept;
        if (begin + mapped > tail) munmap(reinterpret_cast<void*>(tail), begin + mapped - tail);
        madvise(reinterpret_cast<void*>(aligned), kept, MADV_HUGEPAGE);
        return reinterpret_cast<void*>(aligned);
    }
#endif
    return ::operator new(bytes, kLargeAlignment);
}

void freeLarge(void* data, [[maybe_unused]] size_t bytes) noexcept {
    if (!data) return;
#if defined(RAYPACK_LARGE_MAPPINGS)
    if (bytes >= kHugePageBytes) {
        keptMappings().keep(data, mappedBytes(bytes));
        return;
    }
#endif
    ::operator delete(data, kLargeAlignment);
}

}  // namespace raypack
