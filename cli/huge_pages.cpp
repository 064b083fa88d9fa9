// The psub program's global operator new: the memory malloc hands out is advised to use
// transparent huge pages (madvise MADV_HUGEPAGE over whole 2 MiB pages: the heap as it grows,
// and each block of 2 MiB or more mapped on its own), so that filling it takes one page fault
// per 2 MiB instead of one per 4 KiB. The kernel's "madvise" mode (Debian's default) gives
// huge pages only where advised; "always" needs no advice, "never" ignores it. Where page
// faults are dear (this project's VM, bench/README.md "Session 15") `psub play` of a 1M-face
// torus started about 3x sooner. Blocks still come from malloc and go back to free, so new
// and delete pair as before. Not in the library (a program that links it may set
// GLIBC_TUNABLES=glibc.malloc.hugetlb=1 for the same effect, README.md) nor in sanitizer
// builds (their allocators are their own).
#include <sys/mman.h>

#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <string_view>

// Sanitizer builds (GCC's and clang's spellings) keep their own operator new.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define PSUB_OWN_OPERATOR_NEW 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define PSUB_OWN_OPERATOR_NEW 0
#endif
#endif
#if !defined(PSUB_OWN_OPERATOR_NEW) && defined(__linux__)
#define PSUB_OWN_OPERATOR_NEW 1
#endif

#if PSUB_OWN_OPERATOR_NEW

namespace {

constexpr std::uintptr_t kHugePage = std::uintptr_t(2) << 20;
std::atomic<std::uintptr_t> advisedHeapEnd{0};

void advise(std::uintptr_t begin, std::uintptr_t end) {
    begin = (begin + kHugePage - 1) & ~(kHugePage - 1);
    end &= ~(kHugePage - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // advice: errors ignored
}

// PSUB_HUGE_PAGES=0 in the environment turns the advice off (to compare, or where huge pages
// cost more than they save).
bool adviseHugePages() {
    static const bool advise = [] {
        const char* value = std::getenv("PSUB_HUGE_PAGES");
        return !(value && std::string_view(value) == "0");
    }();
    return advise;
}

void* allocate(std::size_t size) {
    void* block = std::malloc(size == 0 ? 1 : size);
    if (!block) throw std::bad_alloc();
    if (!adviseHugePages()) return block;
    // The heap (blocks under malloc's mmap threshold), as it grows: up to its last whole 2 MiB
    // page, once. It grows 64 MiB at a time (M_TOP_PAD, cli/main.cpp), so most of what is
    // advised is not touched yet and faults in huge pages.
    const std::uintptr_t heapEnd = reinterpret_cast<std::uintptr_t>(sbrk(0)) & ~(kHugePage - 1);
    std::uintptr_t advised = advisedHeapEnd.load(std::memory_order_relaxed);
    while (heapEnd > advised && !advisedHeapEnd.compare_exchange_weak(advised, heapEnd)) {
    }
    if (heapEnd > advised && advised != 0) advise(advised, heapEnd);
    // A block of 2 MiB or more in a mapping of its own (over malloc's mmap threshold).
    const std::uintptr_t begin = reinterpret_cast<std::uintptr_t>(block);
    if (size >= kHugePage && begin >= heapEnd + kHugePage) advise(begin, begin + size);
    return block;
}

}  // namespace

void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void operator delete(void* block) noexcept { std::free(block); }
void operator delete[](void* block) noexcept { std::free(block); }
void operator delete(void* block, std::size_t) noexcept { std::free(block); }
void operator delete[](void* block, std::size_t) noexcept { std::free(block); }

#endif
